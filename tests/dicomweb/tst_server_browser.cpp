// dicomweb.server_browser: the demo's File › Open from Server… (demo/serverbrowser.*) driven
// under X (xcb, like the widget suites) against a real Orthanc with basic authentication,
// holding the eight QIDO test studies (qido_studies.h):
//   * a wrong password shows a clear 401 error in the dialog, without the password;
//   * with the right one, studies page by page (pages of 3 over the 7 SM studies), a search by
//     patient name, the study's series (SM in bold);
//   * Open hands the credentials to the view and opens the series URL: the slide opens and a
//     frame is presented; the recent-files list holds the URL exactly, and nothing in the
//     settings holds the password;
//   * File › Keep Server Frames on This Computer (on by default) keeps the fetched frames in the
//     user's cache folder (its own, mode 0700), for the Compare window's views too; File › Clear
//     Kept Server Frames removes them (the next frames kept make the folder again); turned off,
//     nothing is kept;
//   * View › Compare shows the protected series too (the Compare window's views get the main
//     view's credentials).
// Every wait is a signal (QSignalSpy, QTRY_*) with a bounded timeout; nothing sleeps a guess.
#include <memory>

#include <QtCore/QDirIterator>
#include <QtCore/QFileInfo>
#include <QtCore/QSettings>
#include <QtCore/QStandardPaths>
#include <QtGui/QFont>
#include <QtTest/QSignalSpy>
#include <QtTest/QTest>
#include <QtWidgets/QApplication>
#include <QtWidgets/QComboBox>
#include <QtWidgets/QLabel>
#include <QtWidgets/QLineEdit>
#include <QtWidgets/QPushButton>
#include <QtWidgets/QTableWidget>

#include <iris/IrisSlideView.h>

#include "comparepane.h"
#include "comparewindow.h"
#include "enginehost_p.h"
#include "mainwindow.h"
#include "orthanc_server.h"
#include "qido_studies.h"
#include "recentfiles.h"
#include "serverbrowser.h"
#include "test_support.h"
#include "widget_test_support.h"

using namespace dicomwebtest;

namespace {

constexpr int kTimeoutMs = 30000;
const QString kUser = QStringLiteral("iris");
const QString kPassword = QStringLiteral("br0wser-Secret");

template <class T>
T *child(QObject *parent, const char *name)
{
    T *found = parent->findChild<T *>(QLatin1String(name));
    if (!found)
        qWarning("no child %s", name);
    return found;
}

} // namespace

class TstServerBrowser : public QObject {
    Q_OBJECT

    std::unique_ptr<OrthancServer> m_server;
    std::vector<MadeStudy> m_studies;
    std::unique_ptr<MainWindow> m_main;

private Q_SLOTS:
    void initTestCase()
    {
        QCOMPARE(QGuiApplication::platformName(), QStringLiteral("xcb"));
        QVERIFY2(!qEnvironmentVariableIsEmpty("XDG_CONFIG_HOME"), "the test's settings need a folder of their own");
        QApplication::setOrganizationName(QStringLiteral("IrisView"));
        QApplication::setApplicationName(QStringLiteral("tst_server_browser"));
        QSettings().clear();
        IrisSlideView::setVulkanValidation(true);
        if (std::system("command -v Orthanc > /dev/null 2>&1") != 0)
            QFAIL("Orthanc (Debian orthanc, orthanc-dicomweb) is not installed: scripts/install-deps.sh installs it");
        auto boxes = iristest::slidesDir("unsupported/dicom-boxes");
        if (!boxes)
            QSKIP("no test data");
        const fs::path out = iristest::testOutDir() / "dicomweb-server-browser";
        std::string why;
        const std::vector<StudySpec> specs = standardStudies();
        for (size_t i = 0; i < specs.size(); ++i) {
            MadeStudy m;
            QVERIFY2(makeStudy(*boxes, out / ("study-" + std::to_string(i + 1)), specs[i], &m, &why), why.c_str());
            m_studies.push_back(m);
        }
        m_server = OrthancServer::start(out / "orthanc", {kUser.toStdString(), kPassword.toStdString()}, &why);
        QVERIFY2(m_server, why.c_str());
        for (const auto &m : m_studies)
            QVERIFY2(m_server->upload(m.folder, &why), why.c_str());
    }

    void cleanupTestCase()
    {
        if (m_main) {
            const auto *view = m_main->findChild<IrisSlideView *>(QStringLiteral("slideView"));
            QVERIFY(view);
            QCOMPARE(view->validationMessageCount(), quint64(0));
        }
        m_main.reset();
        QCOMPARE(IrisWidget::EngineHost::liveEngineCount(), 0);
        if (m_server)
            QVERIFY(m_server->stop());
        QSettings().clear();
    }

    void findAndOpenASeries()
    {
        m_main = std::make_unique<MainWindow>();
        m_main->resize(900, 650);
        m_main->show();
        QVERIFY(QTest::qWaitForWindowExposed(m_main.get()));
        auto *view = m_main->findChild<IrisSlideView *>(QStringLiteral("slideView"));
        QVERIFY(view);

        // Through the menu action, as a user would.
        auto *action = m_main->findChild<QAction *>(QStringLiteral("openFromServerAction"));
        QVERIFY(action);
        action->trigger();
        auto *browser = m_main->findChild<ServerBrowser *>();
        QVERIFY(browser);
        QTRY_VERIFY_WITH_TIMEOUT(browser->isVisible(), kTimeoutMs);
        browser->setPageSize(3);
        auto *url = child<QLineEdit>(browser, "serverUrl");
        auto *auth = child<QComboBox>(browser, "authKind");
        auto *user = child<QLineEdit>(browser, "user");
        auto *secret = child<QLineEdit>(browser, "secret");
        auto *patientName = child<QLineEdit>(browser, "patientName");
        auto *search = child<QPushButton>(browser, "search");
        auto *next = child<QPushButton>(browser, "nextPage");
        auto *previous = child<QPushButton>(browser, "previousPage");
        auto *studies = child<QTableWidget>(browser, "studies");
        auto *series = child<QTableWidget>(browser, "series");
        auto *open = child<QPushButton>(browser, "open");
        QVERIFY(url && auth && user && secret && patientName && search && next && previous && studies && series
                && open);
        QSignalSpy shown(browser, &ServerBrowser::studiesShown);
        QSignalSpy failed(browser, &ServerBrowser::searchFailed);
        QSignalSpy seriesShown(browser, &ServerBrowser::seriesShown);

        // A wrong password: a clear 401 error in the dialog, which never shows the password.
        url->setText(QString::fromStdString(m_server->dicomWebRoot()));
        auth->setCurrentIndex(auth->findData(int(IrisSlideView::NetworkCredentials::Basic)));
        QVERIFY(user->isEnabled());
        user->setText(kUser);
        secret->setText(QStringLiteral("wrong-password"));
        QTest::mouseClick(search, Qt::LeftButton);
        QTRY_COMPARE_WITH_TIMEOUT(failed.count(), 1, kTimeoutMs);
        const QString error = failed.at(0).at(0).toString();
        qInfo("%s", qPrintable(error));
        QVERIFY2(error.contains(QStringLiteral("refused the credentials given"))
                     && error.contains(QStringLiteral("HTTP 401")),
                 qPrintable(error));
        QVERIFY(!error.contains(QStringLiteral("wrong-password")));
        QCOMPARE(browser->errorText(), error);
        QCOMPARE(shown.count(), 0);

        // The right one: pages of 3 over the 7 SM studies.
        secret->setText(kPassword);
        QTest::mouseClick(search, Qt::LeftButton);
        QTRY_COMPARE_WITH_TIMEOUT(shown.count(), 1, kTimeoutMs);
        QCOMPARE(shown.last().at(0).toInt(), 3);
        QVERIFY(browser->errorText().isEmpty());
        QVERIFY(next->isEnabled());
        QVERIFY(!previous->isEnabled());
        QStringList seen;
        const auto collect = [&] {
            for (int r = 0; r < studies->rowCount(); ++r)
                seen << studies->item(r, 2)->text(); // accession numbers
        };
        collect();
        QTest::mouseClick(next, Qt::LeftButton);
        QTRY_COMPARE_WITH_TIMEOUT(shown.count(), 2, kTimeoutMs);
        QCOMPARE(shown.last().at(0).toInt(), 3);
        collect();
        QTest::mouseClick(next, Qt::LeftButton);
        QTRY_COMPARE_WITH_TIMEOUT(shown.count(), 3, kTimeoutMs);
        QCOMPARE(shown.last().at(0).toInt(), 1);
        collect();
        QVERIFY(!next->isEnabled());
        QVERIFY(previous->isEnabled());
        seen.sort();
        QCOMPARE(seen, (QStringList{QStringLiteral("ACC-1"), QStringLiteral("ACC-2"), QStringLiteral("ACC-3"),
                                    QStringLiteral("ACC-4"), QStringLiteral("ACC-5"), QStringLiteral("ACC-6"),
                                    QStringLiteral("ACC-7")}));
        QTest::mouseClick(previous, Qt::LeftButton);
        QTRY_COMPARE_WITH_TIMEOUT(shown.count(), 4, kTimeoutMs);
        QCOMPARE(shown.last().at(0).toInt(), 3);

        // One patient; its study's series, SM in bold; open it.
        patientName->setText(QStringLiteral("doe^jane2"));
        QTest::mouseClick(search, Qt::LeftButton);
        QTRY_COMPARE_WITH_TIMEOUT(shown.count(), 5, kTimeoutMs);
        QCOMPARE(shown.last().at(0).toInt(), 1);
        QCOMPARE(studies->item(0, 0)->text(), QStringLiteral("Doe^Jane2"));
        QVERIFY(!open->isEnabled());
        studies->selectRow(0);
        QTRY_COMPARE_WITH_TIMEOUT(seriesShown.count(), 1, kTimeoutMs);
        QCOMPARE(seriesShown.last().at(0).toInt(), 1);
        QCOMPARE(series->item(0, 1)->text(), QStringLiteral("SM"));
        QVERIFY(series->item(0, 1)->font().bold());
        series->selectRow(0);
        QVERIFY(open->isEnabled());
        QSignalSpy opened(view, &IrisSlideView::slideOpened);
        QSignalSpy frames(view, &IrisSlideView::framePresented);
        QTest::mouseClick(open, Qt::LeftButton); // opens in the click (the view reads the metadata)
        QTRY_COMPARE_WITH_TIMEOUT(opened.count(), 1, kTimeoutMs);
        const MadeStudy &m = m_studies[1];
        const QString expected = QString::fromStdString(m_server->dicomWebRoot() + "/studies/" + m.studyUid
                                                        + "/series/" + m.seriesUid);
        QCOMPARE(view->slidePath(), expected);
        QVERIFY(view->hasNetworkCredentials());
        QTRY_VERIFY_WITH_TIMEOUT(frames.count() > 0, kTimeoutMs);
        QTRY_VERIFY_WITH_TIMEOUT(!browser->isVisible(), kTimeoutMs);

        // File › Keep Server Frames on This Computer is on by default: the frames fetched are
        // kept in the user's cache folder (written by the cache's own thread: polled).
        auto* keep = m_main->findChild<QAction*>(QStringLiteral("keepFramesAction"));
        QVERIFY(keep && keep->isChecked());
        const QString cacheDir =
            QStandardPaths::writableLocation(QStandardPaths::CacheLocation) + QStringLiteral("/dicomweb-frames");
        QCOMPARE(view->frameCacheDirectory(), cacheDir);
        const auto keptFiles = [&] {
            int n = 0;
            QDirIterator it(cacheDir, QDir::Files, QDirIterator::Subdirectories);
            while (it.hasNext()) {
                it.next();
                n += it.fileName().size() == 16;
            }
            return n;
        };
        QTRY_VERIFY_WITH_TIMEOUT(keptFiles() > 0, kTimeoutMs);
        QCOMPARE(QFileInfo(cacheDir).permissions() & (QFile::ReadGroup | QFile::ReadOther | QFile::ExeOther),
                 QFileDevice::Permissions());

        // View › Compare: the protected series opens in the Compare window's view too (its
        // views get the main view's credentials; without them Orthanc answers 401).
        {
            CompareWindow *compare = m_main->compare({});
            QVERIFY(compare);
            QCOMPARE(compare->count(), 1);
            QVERIFY(compare->view(0)->hasNetworkCredentials());
            QCOMPARE(compare->view(0)->frameCacheDirectory(), cacheDir);
            // Opened (or failed) once its view is on screen.
            QTRY_VERIFY_WITH_TIMEOUT(compare->pane(0)->pendingPath().isEmpty(), kTimeoutMs);
            QVERIFY2(compare->view(0)->hasSlide(), "the Compare window could not open the protected series");
            QCOMPARE(compare->view(0)->slidePath(), expected);
            QSignalSpy compareFrames(compare->view(0), &IrisSlideView::framePresented);
            QTRY_VERIFY_WITH_TIMEOUT(compareFrames.count() > 0, kTimeoutMs);
            compare->close(); // deleted on close
        }

        // File › Clear Kept Server Frames removes them all; the next frame kept makes the
        // folder again (the series opened again fetches its frames and keeps them).
        auto* clear = m_main->findChild<QAction*>(QStringLiteral("clearFramesAction"));
        QVERIFY(clear);
        QVERIFY(m_main->clearKeptFrames() > 0);
        QVERIFY(!QFileInfo::exists(cacheDir));
        QCOMPARE(keptFiles(), 0);
        QSignalSpy reopened(view, &IrisSlideView::framePresented);
        QVERIFY(view->openSlide(expected));
        QTRY_VERIFY_WITH_TIMEOUT(reopened.count() > 0, kTimeoutMs);
        QTRY_VERIFY_WITH_TIMEOUT(keptFiles() > 0, kTimeoutMs);
        QCOMPARE(QFileInfo(cacheDir).permissions() & (QFile::ReadGroup | QFile::ReadOther | QFile::ExeOther),
                 QFileDevice::Permissions());

        // Turned off: remembered, and the series opened from then on keep nothing.
        keep->trigger();
        QVERIFY(view->frameCacheDirectory().isEmpty());
        QCOMPARE(QSettings().value(QStringLiteral("network/keepFrames")).toBool(), false);
        keep->trigger();
        QCOMPARE(view->frameCacheDirectory(), cacheDir);

        // The recent list keeps the URL as it is; no setting holds the password.
        QSettings settings;
        settings.sync();
        QCOMPARE(settings.value(QStringLiteral("recentFiles")).toStringList(), QStringList{expected});
        for (const QString &key : settings.allKeys()) {
            const QString value = settings.value(key).toString() + settings.value(key).toStringList().join(QLatin1Char(' '));
            QVERIFY2(!value.contains(kPassword), qPrintable(QStringLiteral("setting %1 holds the password").arg(key)));
        }
        QFile file(settings.fileName());
        if (file.open(QIODevice::ReadOnly))
            QVERIFY2(!file.readAll().contains(kPassword.toUtf8()), "the settings file holds the password");
        QCOMPARE(RecentFiles::entryFor(expected), expected);
        QCOMPARE(RecentFiles::entryFor(QStringLiteral("https://u:p@pacs.example/dicom-web/studies/1.2/series/3.4")),
                 QStringLiteral("https://pacs.example/dicom-web/studies/1.2/series/3.4"));
    }
};

IRIS_WIDGET_TEST_MAIN(TstServerBrowser)

#include "tst_server_browser.moc"
