#include "orthanc_server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <string_view>
#include <thread>
#include <vector>

#include <curl/curl.h>

#include <dcmtk/config/osconfig.h>

#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>

namespace dicomwebtest {

namespace {

size_t collect(char* data, size_t size, size_t n, void* out) {
    static_cast<std::string*>(out)->append(data, size * n);
    return size * n;
}

// One request with the server's credentials and CA; the HTTP status, or 0 when none came.
long request(const std::string& url, const OrthancOptions& o, const std::string* body, std::string* answer,
             long timeoutMs) {
    CURL* e = curl_easy_init();
    if (!e) return 0;
    std::string sink;
    curl_easy_setopt(e, CURLOPT_URL, url.c_str());
    curl_easy_setopt(e, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(e, CURLOPT_TIMEOUT_MS, timeoutMs);
    curl_easy_setopt(e, CURLOPT_WRITEFUNCTION, &collect);
    curl_easy_setopt(e, CURLOPT_WRITEDATA, answer ? answer : &sink);
    if (!o.user.empty()) {
        curl_easy_setopt(e, CURLOPT_USERNAME, o.user.c_str());
        curl_easy_setopt(e, CURLOPT_PASSWORD, o.password.c_str());
    }
    curl_slist* headers = nullptr;
    if (body) {
        headers = curl_slist_append(headers, "Content-Type: application/dicom");
        curl_easy_setopt(e, CURLOPT_HTTPHEADER, headers);
        curl_easy_setopt(e, CURLOPT_POSTFIELDS, body->data());
        curl_easy_setopt(e, CURLOPT_POSTFIELDSIZE_LARGE, curl_off_t(body->size()));
    }
    long status = 0;
    if (curl_easy_perform(e) == CURLE_OK) curl_easy_getinfo(e, CURLINFO_RESPONSE_CODE, &status);
    curl_slist_free_all(headers);
    curl_easy_cleanup(e);
    return status;
}

std::string dicomString(const fs::path& file, const DcmTagKey& tag) {
    DcmFileFormat ff;
    OFString s;
    if (ff.loadFile(OFFilename(file.c_str())).good()) ff.getDataset()->findAndGetOFString(tag, s);
    return s.c_str();
}

fs::path dicomWebPlugin() {
    for (const auto& e : fs::directory_iterator("/usr/lib/orthanc"))
        if (e.path().filename().string().rfind("libOrthancDicomWeb.so", 0) == 0) return e.path();
    return {};
}

} // namespace

int freeLoopbackPort() {
    const int s = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (s < 0) return 0;
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    int port = 0;
    if (::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
        ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
        port = ntohs(a.sin_port);
    }
    ::close(s);
    return port;
}

std::unique_ptr<OrthancServer> OrthancServer::start(const fs::path& dir, const OrthancOptions& options,
                                                    std::string* why) {
    curl_global_init(CURL_GLOBAL_DEFAULT);
    std::unique_ptr<OrthancServer> s(new OrthancServer());
    s->dir_ = dir;
    s->logPath_ = dir / "orthanc.log";
    s->options_ = options;
    fs::remove_all(dir);
    fs::create_directories(dir / "storage");
    const fs::path plugin = dicomWebPlugin();
    if (plugin.empty()) {
        *why = "the Orthanc DICOMweb plugin (Debian orthanc-dicomweb) is not in /usr/lib/orthanc";
        return nullptr;
    }
    s->port_ = freeLoopbackPort();
    std::ofstream cfg(dir / "orthanc.json");
    cfg << "{\n"
        << "  \"Name\": \"iris-dicomweb-test\",\n"
        << "  \"StorageDirectory\": \"" << (dir / "storage").string() << "\",\n"
        << "  \"IndexDirectory\": \"" << (dir / "storage").string() << "\",\n"
        << "  \"HttpPort\": " << s->port_ << ",\n"
        << "  \"RemoteAccessAllowed\": false,\n"
        << "  \"DicomServerEnabled\": false,\n" // no DICOM port: suites run side by side
        << "  \"Plugins\": [\"" << plugin.string() << "\"],\n"
        << "  \"DicomWeb\": {\"Enable\": true, \"Root\": \"/dicom-web/\", \"EnableWado\": false},\n";
    if (!options.user.empty()) {
        cfg << "  \"AuthenticationEnabled\": true,\n  \"RegisteredUsers\": {\"" << options.user << "\": \""
            << options.password << "\"},\n";
    } else {
        cfg << "  \"AuthenticationEnabled\": false,\n";
    }
    cfg << "  \"HttpThreadsCount\": 16\n}\n";
    cfg.close();
    if (!s->launch(why)) return nullptr;
    return s;
}

bool OrthancServer::launch(std::string* why) {
    // posix_spawn, not fork: the suite's process has engine threads running.
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, logPath_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    const std::string cfg = (dir_ / "orthanc.json").string();
    // Through setpriv (util-linux, Essential): Orthanc gets SIGTERM should the suite die before
    // it stops it (a crash, a timeout's SIGKILL), so no server outlives a failed run. (The
    // signal follows the spawning thread: the suite's main thread.)
    char* argv[] = {const_cast<char*>("setpriv"), const_cast<char*>("--pdeathsig"), const_cast<char*>("TERM"),
                    const_cast<char*>("--"),      const_cast<char*>("Orthanc"),      const_cast<char*>(cfg.c_str()),
                    nullptr};
    // The suite's environment without the sanitizer runtime the asan and tsan presets preload
    // into test programs: Orthanc is not built for it.
    std::vector<char*> env;
    for (char** e = environ; *e; ++e) {
        const std::string_view v(*e);
        if (v.rfind("LD_PRELOAD=", 0) == 0 || v.find("SAN_OPTIONS=") != std::string_view::npos) continue;
        env.push_back(*e);
    }
    env.push_back(nullptr);
    pid_t pid = -1;
    const int rc = ::posix_spawnp(&pid, "setpriv", &actions, nullptr, argv, env.data());
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) {
        *why = std::string("cannot start Orthanc (Debian orthanc): ") + std::strerror(rc);
        return false;
    }
    pid_ = pid;
    // Ready when GET /system answers; the process must still be running meanwhile.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    const std::string url = "http://127.0.0.1:" + std::to_string(port_) + "/system";
    while (std::chrono::steady_clock::now() < deadline) {
        int status = 0;
        if (::waitpid(pid_, &status, WNOHANG) == pid_) {
            pid_ = -1;
            *why = "Orthanc exited at start (see " + logPath_.string() + ")";
            return false;
        }
        if (request(url, options_, nullptr, nullptr, 1000) == 200) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    stop();
    *why = "Orthanc did not answer on port " + std::to_string(port_) + " within 30 s (see " + logPath_.string() + ")";
    return false;
}

bool OrthancServer::stop() {
    if (pid_ <= 0) return true;
    ::kill(pid_, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (std::chrono::steady_clock::now() < deadline) {
        int status = 0;
        if (::waitpid(pid_, &status, WNOHANG) == pid_) {
            pid_ = -1;
            return true;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return true;
}

bool OrthancServer::restart(std::string* why) {
    stop();
    return launch(why);
}

OrthancServer::~OrthancServer() { stop(); }

std::string OrthancServer::dicomWebRoot() const { return "http://127.0.0.1:" + std::to_string(port_) + "/dicom-web"; }

std::string OrthancServer::seriesUrl(const fs::path& dicomFile) const {
    return dicomWebRoot() + "/studies/" + dicomString(dicomFile, DCM_StudyInstanceUID) + "/series/" +
           dicomString(dicomFile, DCM_SeriesInstanceUID);
}

bool OrthancServer::upload(const fs::path& path, std::string* why) const {
    std::vector<fs::path> files;
    if (fs::is_directory(path)) {
        for (const auto& e : fs::directory_iterator(path))
            if (e.is_regular_file()) files.push_back(e.path());
    } else {
        files.push_back(path);
    }
    for (const fs::path& f : files) {
        std::ifstream in(f, std::ios::binary);
        const std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::string answer;
        const long status =
            request("http://127.0.0.1:" + std::to_string(port_) + "/instances", options_, &body, &answer, 60000);
        if (status != 200) {
            *why = "uploading " + f.string() + " to Orthanc gave HTTP " + std::to_string(status) + ": " +
                   answer.substr(0, 300);
            return false;
        }
    }
    return true;
}

} // namespace dicomwebtest
