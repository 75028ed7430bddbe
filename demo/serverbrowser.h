// Iris View demo — File › Open from Server…: finds slides on a DICOMweb server through QIDO-RS
// (iris::dicomweb::QidoClient) and opens the chosen series.
//
// The server URL, the credentials (none, HTTP basic, bearer token; a CA file) and the search
// fields are typed in; studies show in one table (page by page), the selected study's series in
// another (SM, slide microscopy, in bold; "SM only" filters both searches). Errors show in the
// dialog. Opening a series emits openRequested with the series URL and the credentials, which
// the main window hands to IrisSlideView::setNetworkCredentials before openSlide(url).
//
// Credentials live in this dialog's fields only, for the session: nothing of them is written
// to QSettings, the recent-files list or a log line. The main window keeps the dialog (hidden)
// so that they are there when it is shown again.
//
// Threads: every search runs on a QThreadPool thread (QidoClient blocks until the answer,
// bounded by NetworkOptions' timeouts); its result comes back to the GUI thread through a
// queued call guarded by a QPointer, and is dropped when a newer search was started since
// (m_studyGeneration, m_seriesGeneration) or the dialog is gone. The client is shared with the task, so it outlives
// a dialog closed mid-search.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <QtWidgets/QDialog>

#include <iris/IrisSlideView.h>
#include <iris/dicomweb.h>

QT_BEGIN_NAMESPACE
class QCheckBox;
class QComboBox;
class QLabel;
class QLineEdit;
class QPushButton;
class QTableWidget;
QT_END_NAMESPACE

class ServerBrowser : public QDialog {
    Q_OBJECT
public:
    static constexpr uint32_t kDefaultPageSize = 25;

    explicit ServerBrowser(QWidget *parent = nullptr);
    ~ServerBrowser() override;

    // The credentials as typed in (openRequested carries the ones the series was found with).
    IrisSlideView::NetworkCredentials credentials() const;
    // The error shown, or empty.
    QString errorText() const;
    bool isBusy() const { return m_busy > 0; }
    // Studies per page (1…1000; tests use a small one to page over a few studies).
    void setPageSize(uint32_t studies) { m_pageSize = studies < 1 ? 1 : studies > 1000 ? 1000 : studies; }

public Q_SLOTS:
    // Searches studies from the first page.
    void search();
    void nextPage();
    void previousPage();
    // Opens the selected series (emits openRequested).
    void openSelected();

Q_SIGNALS:
    void openRequested(const QString &seriesUrl, const IrisSlideView::NetworkCredentials &credentials);
    // A search ended (for tests and the status line): the rows shown, or the error shown.
    void studiesShown(int count);
    void seriesShown(int count);
    void searchFailed(const QString &message);

private:
    // The client for the URL and credentials typed in now (made again when they changed).
    std::shared_ptr<iris::dicomweb::QidoClient> client(QString *error);
    iris::NetworkOptions networkOptions() const;
    void searchStudies(uint32_t offset);
    void searchSeries(const QString &studyUid);
    void showStudies(const iris::dicomweb::Page<iris::dicomweb::Study> &page, uint32_t offset);
    void showSeries(const iris::dicomweb::Page<iris::dicomweb::Series> &page);
    void showError(const QString &message);
    void setBusy(bool busy);
    void updateButtons();

    QLineEdit *m_url;
    QComboBox *m_auth;
    QLineEdit *m_user;
    QLineEdit *m_secret;
    QLineEdit *m_caFile;
    QCheckBox *m_verifyTls;
    QLineEdit *m_patientName;
    QLineEdit *m_patientId;
    QLineEdit *m_accession;
    QLineEdit *m_dateFrom;
    QLineEdit *m_dateTo;
    QLineEdit *m_description;
    QCheckBox *m_slidesOnly;
    QPushButton *m_searchButton;
    QPushButton *m_previousButton;
    QPushButton *m_nextButton;
    QLabel *m_pageLabel;
    QTableWidget *m_studies;
    QTableWidget *m_series;
    QLabel *m_error;
    QPushButton *m_openButton;

    std::shared_ptr<iris::dicomweb::QidoClient> m_client;
    QString m_clientUrl;             // what m_client was made for
    iris::NetworkOptions m_clientOptions;
    IrisSlideView::NetworkCredentials m_clientCredentials; // what the results shown were found with
    std::vector<iris::dicomweb::Study> m_studyRows;
    std::vector<iris::dicomweb::Series> m_seriesRows;
    uint32_t m_pageSize = kDefaultPageSize;
    uint32_t m_offset = 0;
    bool m_more = false;
    uint64_t m_studyGeneration = 0;  // of the newest study search; older answers are dropped
    uint64_t m_seriesGeneration = 0; // the same for series
    int m_busy = 0;
};
