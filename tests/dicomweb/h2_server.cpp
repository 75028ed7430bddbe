#include "h2_server.h"

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

#include "orthanc_server.h" // freeLoopbackPort

extern char** environ;

namespace dicomwebtest {

namespace {

bool accepts(int port) {
    const int s = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (s < 0) return false;
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(uint16_t(port));
    const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    ::close(s);
    return ok;
}

} // namespace

std::unique_ptr<H2Server> H2Server::start(const fs::path& dir, int backendPort, const fs::path& certificate,
                                          const fs::path& key, std::string* why) {
    std::unique_ptr<H2Server> s(new H2Server());
    s->dir_ = dir;
    fs::remove_all(dir);
    fs::create_directories(dir);
    s->port_ = freeLoopbackPort();
    if (s->port_ <= 0) {
        *why = "no free loopback port";
        return nullptr;
    }
    const fs::path log = dir / "nghttpx.log";
    const std::vector<std::string> args = {
        "setpriv", "--pdeathsig", "TERM", "--", // gone with the suite, should it die first
        "nghttpx",
        "--conf=/dev/null", // not /etc/nghttpx's
        "--frontend=127.0.0.1," + std::to_string(s->port_),
        "--backend=127.0.0.1," + std::to_string(backendPort),
        "--single-process", "--workers=1", "--no-ocsp",
        "--accesslog-file=" + (dir / "access.log").string(),
        "--accesslog-format=$alpn $remote_port $method $path $status",
        "--errorlog-file=" + log.string(),
        key.string(), certificate.string()};
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    // The suite's environment without the sanitizer runtime the asan and tsan presets preload.
    std::vector<char*> env;
    for (char** e = environ; *e; ++e) {
        const std::string_view v(*e);
        if (v.rfind("LD_PRELOAD=", 0) == 0 || v.find("SAN_OPTIONS=") != std::string_view::npos) continue;
        env.push_back(*e);
    }
    env.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    pid_t pid = -1;
    const int rc = ::posix_spawnp(&pid, "setpriv", &actions, nullptr, argv.data(), env.data());
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) {
        *why = std::string("cannot start nghttpx (Debian nghttp2-proxy): ") + std::strerror(rc);
        return nullptr;
    }
    s->pid_ = pid;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
    while (std::chrono::steady_clock::now() < deadline) {
        int status = 0;
        if (::waitpid(pid, &status, WNOHANG) == pid) {
            s->pid_ = -1;
            *why = "nghttpx exited at start (see " + log.string() + ")";
            return nullptr;
        }
        if (accepts(s->port_)) return s;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    *why = "nghttpx did not listen on port " + std::to_string(s->port_) + " within 15 s (see " + log.string() + ")";
    return nullptr; // the destructor stops it
}

H2Server::~H2Server() { stop(); }

bool H2Server::stop() {
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

std::vector<std::string> H2Server::accessLog() const {
    std::vector<std::string> lines;
    std::ifstream in(dir_ / "access.log");
    for (std::string line; std::getline(in, line);)
        if (!line.empty()) lines.push_back(line);
    return lines;
}

} // namespace dicomwebtest
