#include "serverbrowser.h"

#include <QtCore/QFile>
#include <QtCore/QPointer>
#include <QtCore/QThreadPool>
#include <QtGui/QFont>
#include <QtWidgets/QApplication>
#include <QtWidgets/QCheckBox>
#include <QtWidgets/QComboBox>
#include <QtWidgets/QDialogButtonBox>
#include <QtWidgets/QFormLayout>
#include <QtWidgets/QGroupBox>
#include <QtWidgets/QHBoxLayout>
#include <QtWidgets/QHeaderView>
#include <QtWidgets/QLabel>
#include <QtWidgets/QLineEdit>
#include <QtWidgets/QPushButton>
#include <QtWidgets/QSplitter>
#include <QtWidgets/QTableWidget>
#include <QtWidgets/QVBoxLayout>

namespace dw = iris::dicomweb;

namespace {

QString fromStd(const std::string &s)
{
    return QString::fromStdString(s);
}

QTableWidget *makeTable(const QStringList &headers, QWidget *parent)
{
    auto *t = new QTableWidget(0, int(headers.size()), parent);
    t->setHorizontalHeaderLabels(headers);
    t->setSelectionBehavior(QAbstractItemView::SelectRows);
    t->setSelectionMode(QAbstractItemView::SingleSelection);
    t->setEditTriggers(QAbstractItemView::NoEditTriggers);
    t->verticalHeader()->hide();
    t->horizontalHeader()->setStretchLastSection(true);
    return t;
}

QTableWidgetItem *cell(const QString &text, bool bold = false)
{
    auto *item = new QTableWidgetItem(text);
    if (bold) {
        QFont f = item->font();
        f.setBold(true);
        item->setFont(f);
    }
    return item;
}

QString count(int64_t n)
{
    return n < 0 ? QString() : QString::number(n);
}

// "20240103" as "2024-01-03"; anything else as it came.
QString date(const std::string &d)
{
    const QString s = fromStd(d);
    return s.size() == 8 ? s.left(4) + QLatin1Char('-') + s.mid(4, 2) + QLatin1Char('-') + s.mid(6, 2) : s;
}

} // namespace

ServerBrowser::ServerBrowser(QWidget *parent)
    : QDialog(parent)
    , m_url(new QLineEdit(this))
    , m_auth(new QComboBox(this))
    , m_user(new QLineEdit(this))
    , m_secret(new QLineEdit(this))
    , m_caFile(new QLineEdit(this))
    , m_verifyTls(new QCheckBox(tr("Verify the server's certificate"), this))
    , m_patientName(new QLineEdit(this))
    , m_patientId(new QLineEdit(this))
    , m_accession(new QLineEdit(this))
    , m_dateFrom(new QLineEdit(this))
    , m_dateTo(new QLineEdit(this))
    , m_description(new QLineEdit(this))
    , m_slidesOnly(new QCheckBox(tr("Slide microscopy (SM) only"), this))
    , m_searchButton(new QPushButton(tr("&Search"), this))
    , m_previousButton(new QPushButton(tr("< &Previous"), this))
    , m_nextButton(new QPushButton(tr("&Next >"), this))
    , m_pageLabel(new QLabel(this))
    , m_studies(makeTable({tr("Patient"), tr("Patient ID"), tr("Accession"), tr("Date"), tr("Description"),
                           tr("Modalities"), tr("Series")},
                          this))
    , m_series(makeTable({tr("Number"), tr("Modality"), tr("Description"), tr("Instances")}, this))
    , m_error(new QLabel(this))
    , m_openButton(new QPushButton(tr("&Open"), this))
{
    setWindowTitle(tr("Open from Server"));
    // Object names: tests (and style sheets) find the fields by them.
    m_url->setObjectName(QStringLiteral("serverUrl"));
    m_auth->setObjectName(QStringLiteral("authKind"));
    m_user->setObjectName(QStringLiteral("user"));
    m_secret->setObjectName(QStringLiteral("secret"));
    m_caFile->setObjectName(QStringLiteral("caFile"));
    m_patientName->setObjectName(QStringLiteral("patientName"));
    m_patientId->setObjectName(QStringLiteral("patientId"));
    m_accession->setObjectName(QStringLiteral("accessionNumber"));
    m_dateFrom->setObjectName(QStringLiteral("studyDateFrom"));
    m_dateTo->setObjectName(QStringLiteral("studyDateTo"));
    m_description->setObjectName(QStringLiteral("studyDescription"));
    m_slidesOnly->setObjectName(QStringLiteral("slidesOnly"));
    m_searchButton->setObjectName(QStringLiteral("search"));
    m_previousButton->setObjectName(QStringLiteral("previousPage"));
    m_nextButton->setObjectName(QStringLiteral("nextPage"));
    m_studies->setObjectName(QStringLiteral("studies"));
    m_series->setObjectName(QStringLiteral("series"));
    m_error->setObjectName(QStringLiteral("error"));
    m_openButton->setObjectName(QStringLiteral("open"));

    m_url->setPlaceholderText(QStringLiteral("https://pacs.example.org/dicom-web"));
    m_auth->addItem(tr("None"), int(IrisSlideView::NetworkCredentials::None));
    m_auth->addItem(tr("HTTP basic"), int(IrisSlideView::NetworkCredentials::Basic));
    m_auth->addItem(tr("Bearer token"), int(IrisSlideView::NetworkCredentials::Bearer));
    m_secret->setEchoMode(QLineEdit::Password);
    m_caFile->setPlaceholderText(tr("the system's certificate authorities"));
    m_verifyTls->setChecked(true);
    m_patientName->setPlaceholderText(tr("Doe^Jane*  (* and ? are wildcards)"));
    m_dateFrom->setPlaceholderText(tr("YYYYMMDD"));
    m_dateTo->setPlaceholderText(tr("YYYYMMDD"));
    m_slidesOnly->setChecked(true);
    m_error->setWordWrap(true);
    m_error->setTextInteractionFlags(Qt::TextSelectableByMouse);
    m_error->setStyleSheet(QStringLiteral("color: #b00020"));
    m_error->hide();
    m_searchButton->setDefault(true);

    auto *server = new QGroupBox(tr("Server"), this);
    auto *serverForm = new QFormLayout(server);
    serverForm->addRow(tr("DICOMweb &URL:"), m_url);
    serverForm->addRow(tr("&Authentication:"), m_auth);
    serverForm->addRow(tr("U&ser:"), m_user);
    serverForm->addRow(tr("Pass&word / token:"), m_secret);
    serverForm->addRow(tr("&CA file:"), m_caFile);
    serverForm->addRow(QString(), m_verifyTls);

    auto *query = new QGroupBox(tr("Search"), this);
    auto *queryForm = new QFormLayout(query);
    queryForm->addRow(tr("Patient &name:"), m_patientName);
    queryForm->addRow(tr("Patient &ID:"), m_patientId);
    queryForm->addRow(tr("Acc&ession:"), m_accession);
    auto *dates = new QHBoxLayout;
    dates->addWidget(m_dateFrom);
    dates->addWidget(new QLabel(tr("to"), this));
    dates->addWidget(m_dateTo);
    queryForm->addRow(tr("Study &date:"), dates);
    queryForm->addRow(tr("Desc&ription:"), m_description);
    queryForm->addRow(QString(), m_slidesOnly);

    auto *top = new QHBoxLayout;
    top->addWidget(server);
    top->addWidget(query);

    auto *paging = new QHBoxLayout;
    paging->addWidget(m_searchButton);
    paging->addStretch();
    paging->addWidget(m_previousButton);
    paging->addWidget(m_pageLabel);
    paging->addWidget(m_nextButton);

    auto *tables = new QSplitter(Qt::Vertical, this);
    tables->addWidget(m_studies);
    tables->addWidget(m_series);

    auto *buttons = new QDialogButtonBox(this);
    buttons->addButton(m_openButton, QDialogButtonBox::AcceptRole);
    buttons->addButton(QDialogButtonBox::Close);
    connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);

    auto *layout = new QVBoxLayout(this);
    layout->addLayout(top);
    layout->addLayout(paging);
    layout->addWidget(tables, 1);
    layout->addWidget(m_error);
    layout->addWidget(buttons);
    resize(900, 640);

    const auto authChanged = [this] {
        const auto kind = IrisSlideView::NetworkCredentials::Kind(m_auth->currentData().toInt());
        m_user->setEnabled(kind == IrisSlideView::NetworkCredentials::Basic);
        m_secret->setEnabled(kind != IrisSlideView::NetworkCredentials::None);
    };
    connect(m_auth, &QComboBox::currentIndexChanged, this, authChanged);
    authChanged();
    connect(m_searchButton, &QPushButton::clicked, this, &ServerBrowser::search);
    for (QLineEdit *field : {m_patientName, m_patientId, m_accession, m_dateFrom, m_dateTo, m_description, m_url})
        connect(field, &QLineEdit::returnPressed, this, &ServerBrowser::search);
    connect(m_previousButton, &QPushButton::clicked, this, &ServerBrowser::previousPage);
    connect(m_nextButton, &QPushButton::clicked, this, &ServerBrowser::nextPage);
    connect(m_openButton, &QPushButton::clicked, this, &ServerBrowser::openSelected);
    connect(m_studies, &QTableWidget::itemSelectionChanged, this, [this] {
        const int row = m_studies->currentRow();
        m_series->setRowCount(0);
        m_seriesRows.clear();
        if (row >= 0 && size_t(row) < m_studyRows.size())
            searchSeries(fromStd(m_studyRows[size_t(row)].studyInstanceUid));
        updateButtons();
    });
    connect(m_series, &QTableWidget::itemSelectionChanged, this, &ServerBrowser::updateButtons);
    connect(m_series, &QTableWidget::cellDoubleClicked, this, &ServerBrowser::openSelected);
    updateButtons();
}

ServerBrowser::~ServerBrowser()
{
    // Searches still running answer into nothing (their QPointer is null): end their cursor here.
    if (m_busy > 0)
        QApplication::restoreOverrideCursor();
}

IrisSlideView::NetworkCredentials ServerBrowser::credentials() const
{
    IrisSlideView::NetworkCredentials c;
    c.kind = IrisSlideView::NetworkCredentials::Kind(m_auth->currentData().toInt());
    if (c.kind == IrisSlideView::NetworkCredentials::Basic)
        c.user = m_user->text();
    if (c.kind != IrisSlideView::NetworkCredentials::None)
        c.secret = m_secret->text();
    c.caFile = m_caFile->text().trimmed();
    c.verifyTls = m_verifyTls->isChecked();
    return c;
}

QString ServerBrowser::errorText() const
{
    return m_error->text();
}

iris::NetworkOptions ServerBrowser::networkOptions() const
{
    const IrisSlideView::NetworkCredentials c = credentials();
    iris::NetworkOptions o;
    if (c.kind == IrisSlideView::NetworkCredentials::Basic) {
        o.username = c.user.toStdString();
        o.password = c.secret.toStdString();
    } else if (c.kind == IrisSlideView::NetworkCredentials::Bearer) {
        o.bearerToken = c.secret.toStdString();
    }
    o.caFile = QFile::encodeName(c.caFile).toStdString();
    o.verifyTls = c.verifyTls;
    return o;
}

std::shared_ptr<dw::QidoClient> ServerBrowser::client(QString *error)
{
    const QString url = m_url->text().trimmed();
    const iris::NetworkOptions o = networkOptions();
    const bool same = m_client && url == m_clientUrl && o.username == m_clientOptions.username
        && o.password == m_clientOptions.password && o.bearerToken == m_clientOptions.bearerToken
        && o.caFile == m_clientOptions.caFile && o.verifyTls == m_clientOptions.verifyTls;
    if (same)
        return m_client;
    m_client.reset();
    if (url.isEmpty()) {
        *error = tr("Enter the server's DICOMweb URL (for example https://pacs.example.org/dicom-web).");
        return nullptr;
    }
    auto made = dw::QidoClient::create(url.toStdString(), o);
    if (!made.ok()) {
        *error = fromStd(made.error().message());
        return nullptr;
    }
    m_client = std::shared_ptr<dw::QidoClient>(std::move(made).value());
    m_clientUrl = url;
    m_clientOptions = o;
    m_clientCredentials = credentials();
    return m_client;
}

void ServerBrowser::search()
{
    searchStudies(0);
}

void ServerBrowser::nextPage()
{
    if (m_more)
        searchStudies(m_offset + m_pageSize);
}

void ServerBrowser::previousPage()
{
    if (m_offset > 0)
        searchStudies(m_offset >= m_pageSize ? m_offset - m_pageSize : 0);
}

void ServerBrowser::searchStudies(uint32_t offset)
{
    QString error;
    const std::shared_ptr<dw::QidoClient> qido = client(&error);
    if (!qido) {
        showError(error);
        return;
    }
    dw::StudyQuery q;
    q.patientName = m_patientName->text().trimmed().toStdString();
    q.patientId = m_patientId->text().trimmed().toStdString();
    q.accessionNumber = m_accession->text().trimmed().toStdString();
    q.studyDateFrom = m_dateFrom->text().trimmed().remove(QLatin1Char('-')).toStdString();
    q.studyDateTo = m_dateTo->text().trimmed().remove(QLatin1Char('-')).toStdString();
    q.studyDescription = m_description->text().trimmed().toStdString();
    q.modality = m_slidesOnly->isChecked() ? "SM" : "";
    q.limit = m_pageSize;
    q.offset = offset;
    const uint64_t generation = ++m_studyGeneration;
    ++m_seriesGeneration; // a series answer for a study of the old list is of no use now
    setBusy(true);
    QPointer<ServerBrowser> self(this);
    QThreadPool::globalInstance()->start([self, qido, q, generation, offset] {
        auto result = std::make_shared<iris::Expected<dw::Page<dw::Study>>>(qido->searchStudies(q));
        // qApp lives longer than any dialog: the call runs on the GUI thread, where self is checked.
        QMetaObject::invokeMethod(qApp, [self, result, generation, offset] {
            if (!self)
                return;
            self->setBusy(false);
            if (generation != self->m_studyGeneration)
                return;
            if (result->ok())
                self->showStudies(result->value(), offset);
            else
                self->showError(fromStd(result->error().message()));
        }, Qt::QueuedConnection);
    });
}

void ServerBrowser::searchSeries(const QString &studyUid)
{
    QString error;
    const std::shared_ptr<dw::QidoClient> qido = client(&error);
    if (!qido) {
        showError(error);
        return;
    }
    dw::SeriesQuery q;
    q.modality = m_slidesOnly->isChecked() ? "SM" : "";
    q.limit = 1000;
    const uint64_t generation = ++m_seriesGeneration;
    setBusy(true);
    QPointer<ServerBrowser> self(this);
    const std::string study = studyUid.toStdString();
    QThreadPool::globalInstance()->start([self, qido, q, generation, study] {
        auto result = std::make_shared<iris::Expected<dw::Page<dw::Series>>>(qido->searchSeries(study, q));
        QMetaObject::invokeMethod(qApp, [self, result, generation] {
            if (!self)
                return;
            self->setBusy(false);
            if (generation != self->m_seriesGeneration)
                return;
            if (result->ok())
                self->showSeries(result->value());
            else
                self->showError(fromStd(result->error().message()));
        }, Qt::QueuedConnection);
    });
}

void ServerBrowser::showStudies(const dw::Page<dw::Study> &page, uint32_t offset)
{
    m_error->clear();
    m_error->hide();
    m_offset = offset;
    m_more = page.more;
    m_studyRows = page.items;
    m_seriesRows.clear();
    m_series->setRowCount(0);
    {
        const QSignalBlocker block(m_studies); // filling the table selects nothing
        m_studies->setRowCount(0);
        m_studies->setRowCount(int(m_studyRows.size()));
        for (size_t i = 0; i < m_studyRows.size(); ++i) {
            const dw::Study &s = m_studyRows[i];
            QStringList modalities;
            for (const std::string &m : s.modalities)
                modalities << fromStd(m);
            const bool slides = modalities.contains(QStringLiteral("SM"));
            const int row = int(i);
            m_studies->setItem(row, 0, cell(fromStd(s.patientName), slides));
            m_studies->setItem(row, 1, cell(fromStd(s.patientId)));
            m_studies->setItem(row, 2, cell(fromStd(s.accessionNumber)));
            m_studies->setItem(row, 3, cell(date(s.studyDate)));
            m_studies->setItem(row, 4, cell(fromStd(s.studyDescription)));
            m_studies->setItem(row, 5, cell(modalities.join(QStringLiteral(", ")), slides));
            m_studies->setItem(row, 6, cell(count(s.numberOfSeries)));
        }
        m_studies->clearSelection();
    }
    m_studies->resizeColumnsToContents();
    const int first = m_studyRows.empty() ? 0 : int(offset) + 1;
    m_pageLabel->setText(m_studyRows.empty()
                             ? tr("no studies")
                             : tr("studies %1–%2").arg(first).arg(int(offset) + int(m_studyRows.size())));
    updateButtons();
    Q_EMIT studiesShown(int(m_studyRows.size()));
}

void ServerBrowser::showSeries(const dw::Page<dw::Series> &page)
{
    m_error->clear();
    m_error->hide();
    m_seriesRows = page.items;
    {
        const QSignalBlocker block(m_series);
        m_series->setRowCount(0);
        m_series->setRowCount(int(m_seriesRows.size()));
        for (size_t i = 0; i < m_seriesRows.size(); ++i) {
            const dw::Series &s = m_seriesRows[i];
            const bool slide = s.modality == "SM"; // the ones Iris View opens: in bold
            const int row = int(i);
            m_series->setItem(row, 0, cell(count(s.seriesNumber), slide));
            m_series->setItem(row, 1, cell(fromStd(s.modality), slide));
            m_series->setItem(row, 2, cell(fromStd(s.seriesDescription), slide));
            m_series->setItem(row, 3, cell(count(s.numberOfInstances), slide));
        }
        m_series->clearSelection();
    }
    m_series->resizeColumnsToContents();
    updateButtons();
    Q_EMIT seriesShown(int(m_seriesRows.size()));
}

void ServerBrowser::showError(const QString &message)
{
    m_error->setText(message);
    m_error->show();
    updateButtons();
    Q_EMIT searchFailed(message);
}

void ServerBrowser::setBusy(bool busy)
{
    // One busy cursor while any search runs (the dialog stays usable: a newer search wins).
    if (busy) {
        if (m_busy++ == 0)
            QApplication::setOverrideCursor(Qt::BusyCursor);
    } else if (m_busy > 0 && --m_busy == 0) {
        QApplication::restoreOverrideCursor();
    }
    updateButtons();
}

void ServerBrowser::updateButtons()
{
    m_previousButton->setEnabled(m_offset > 0);
    m_nextButton->setEnabled(m_more);
    const int row = m_series->currentRow();
    m_openButton->setEnabled(row >= 0 && size_t(row) < m_seriesRows.size() && !m_series->selectedItems().isEmpty());
}

void ServerBrowser::openSelected()
{
    const int study = m_studies->currentRow();
    const int series = m_series->currentRow();
    if (!m_client || study < 0 || size_t(study) >= m_studyRows.size() || series < 0
        || size_t(series) >= m_seriesRows.size())
        return;
    const dw::Series &s = m_seriesRows[size_t(series)];
    const QString url = fromStd(m_client->seriesUrl(s.studyInstanceUid, s.seriesInstanceUid));
    // The credentials the series was found with, even if the fields were edited since.
    Q_EMIT openRequested(url, m_clientCredentials);
}
