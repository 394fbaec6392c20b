#include "daemon/standcald/server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <grp.h>
#include <netdb.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/timerfd.h>
#include <sys/un.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "daemon/standcald/errno_text.hpp"
#include "daemon/standcald/method_table.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/methods.hpp"
#include "standcal/version.hpp"

namespace standcal::daemon {

using nlohmann::json;
using protocol::ErrorCode;
using protocol::RpcError;
namespace m = protocol::method;

namespace {

RunPageQuery runs_list_query(const protocol::RunsListParams& p) {
  RunPageQuery q;
  q.unit_serial = p.unit_serial.value_or("");
  q.before_run_id = p.before.value_or("");
  q.limit = static_cast<std::size_t>(p.limit.value_or(protocol::runs_list_default_limit));
  return q;
}

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

sockaddr_un unix_address(const std::string& path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof(addr.sun_path)) {
    throw std::runtime_error("socket path too long (max " +
                             std::to_string(sizeof(addr.sun_path) - 1) + " bytes): " + path);
  }
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  return addr;
}

// A socket file left by a crashed daemon is replaced; a live daemon's is not.
void remove_stale_socket(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return;
  if (!S_ISSOCK(st.st_mode))
    throw std::runtime_error(path + " exists and is not a socket; not replacing it");
  const sockaddr_un addr = unix_address(path);
  const int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (probe < 0) throw std::runtime_error("cannot check the socket " + path + ": " + errno_text());
  const bool connected =
      ::connect(probe, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0;
  const int connect_errno = errno;
  ::close(probe);
  if (connected) throw std::runtime_error("another standcald is already listening on " + path);
  // Only "refused" proves nobody listens; a full backlog (EAGAIN) or no permission
  // (EACCES) may hide a live daemon whose socket must not be taken away.
  if (connect_errno != ECONNREFUSED) {
    throw std::runtime_error("cannot tell whether a daemon listens on " + path + " (" +
                             std::strerror(connect_errno) + "); not replacing it");
  }
  spdlog::info("replacing the stale socket {} (left by a daemon that did not exit cleanly)", path);
  ::unlink(path.c_str());
}

const std::set<std::string>& known_events() {
  namespace ev = protocol::event;
  static const std::set<std::string> names{ev::run_progress, ev::position_reached,
                                           ev::position_averaged, ev::run_state, ev::fault};
  return names;
}

// The supplementary groups the kernel recorded for the peer at connect time (the same
// groups that decide its file access); getgrouplist() from the user database when the
// kernel cannot tell (SO_PEERGROUPS is Linux 4.13+).
std::vector<gid_t> peer_groups(int fd, uid_t uid, gid_t gid) {
  std::vector<gid_t> groups(64);
  for (int attempt = 0; attempt < 4; ++attempt) {
    socklen_t len = static_cast<socklen_t>(groups.size() * sizeof(gid_t));
    if (::getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, groups.data(), &len) == 0) {
      groups.resize(len / sizeof(gid_t));
      return groups;
    }
    if (errno != ERANGE) break;
    groups.resize(len / sizeof(gid_t) + 1);
  }
  groups.clear();
  passwd pw{};
  passwd* found = nullptr;
  std::vector<char> buf(16384);
  if (::getpwuid_r(uid, &pw, buf.data(), buf.size(), &found) != 0 || found == nullptr)
    return groups;
  int n = 64;
  groups.assign(static_cast<std::size_t>(n), 0);
  if (::getgrouplist(pw.pw_name, gid, groups.data(), &n) < 0) {
    groups.assign(static_cast<std::size_t>(std::max(n, 0)), 0);
    if (::getgrouplist(pw.pw_name, gid, groups.data(), &n) < 0) n = 0;
  }
  groups.resize(static_cast<std::size_t>(std::max(n, 0)));
  return groups;
}

// The peer's process name, read at accept: the process may be gone when it is logged.
std::string process_name(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/comm");
  std::string name;
  std::getline(in, name);
  return name;
}

Peer unix_peer(int fd) {
  Peer p;
  ucred cred{};
  socklen_t len = sizeof cred;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0) {
    p.credentials_known = true;
    p.pid = cred.pid;
    p.uid = cred.uid;
    p.gid = cred.gid;
    p.groups = peer_groups(fd, cred.uid, cred.gid);
    p.process = process_name(cred.pid);
  }
  return p;
}

Peer tcp_peer(int fd) {
  Peer p;
  p.tcp = true;
  sockaddr_storage addr{};
  socklen_t len = sizeof addr;
  char host[NI_MAXHOST] = "?";
  char port[NI_MAXSERV] = "?";
  if (::getpeername(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0) {
    ::getnameinfo(reinterpret_cast<sockaddr*>(&addr), len, host, sizeof host, port, sizeof port,
                  NI_NUMERICHOST | NI_NUMERICSERV);
  }
  p.address = std::string(host) + ":" + port;
  return p;
}

}  // namespace

bool is_open_method(const std::string& method) {
  const MethodSpec* spec = find_method(method);
  return spec != nullptr && spec->access == Access::anyone;
}

std::optional<std::string> refuse_control(const std::string& method, const Peer& peer,
                                          const AccessPolicy& policy) {
  if (is_open_method(method)) return std::nullopt;
  const std::string refused = method + " not permitted: ";
  if (peer.tcp) {
    if (peer.token_accepted) return std::nullopt;
    if (!policy.tcp_token_configured) {
      return refused +
             "this daemon has no tcp.token_file, so TCP clients may only read and send estop; "
             "use the Unix socket";
    }
    return refused +
           "TCP clients get control only after {\"method\":\"auth\",\"params\":{\"token\":…}} "
           "with the daemon's token (tcp.token_file)";
  }
  if (policy.control_group.empty()) return std::nullopt;
  if (!peer.credentials_known)
    return refused + "the daemon could not read the peer's credentials (SO_PEERCRED)";
  if (peer.uid == 0 || peer.uid == policy.daemon_uid) return std::nullopt;
  const bool member =
      peer.gid == policy.control_gid ||
      std::find(peer.groups.begin(), peer.groups.end(), policy.control_gid) != peer.groups.end();
  if (member) return std::nullopt;
  return refused + "stand and run commands need membership of group \"" + policy.control_group +
         "\" (access.control_group); " + describe_peer(peer) +
         " is not a member. Read-only methods and estop stay open";
}

bool tokens_equal(std::string_view supplied, std::string_view expected) {
  if (expected.empty()) return false;
  unsigned char diff = supplied.size() == expected.size() ? 0 : 1;
  for (std::size_t i = 0; i < supplied.size(); ++i) {
    diff |= static_cast<unsigned char>(supplied[i] ^ expected[i % expected.size()]);
  }
  return diff == 0;
}

std::string describe_peer(const Peer& peer) {
  if (peer.tcp) return "tcp " + peer.address;
  if (!peer.credentials_known) return "a peer of unknown credentials";
  return "uid " + std::to_string(peer.uid) + " gid " + std::to_string(peer.gid) + " pid " +
         std::to_string(peer.pid);
}

std::string describe_peer_process(const Peer& peer) {
  if (peer.process.empty()) return describe_peer(peer);
  return describe_peer(peer) + " (" + protocol::printable(peer.process) + ")";
}

bool may_use_reserved_slot(const Peer& peer, const AccessPolicy& policy) {
  if (peer.tcp || !peer.credentials_known) return false;
  if (peer.uid == 0 || peer.uid == policy.daemon_uid) return true;
  if (policy.control_group.empty()) return false;  // then nobody but root and the daemon is special
  return peer.gid == policy.control_gid ||
         std::find(peer.groups.begin(), peer.groups.end(), policy.control_gid) != peer.groups.end();
}

std::optional<ClientSlot> slot_for_new_client(const SlotsTaken& taken, int max_clients,
                                              bool may_use_reserved) {
  if (taken.regular < max_clients - kReservedControlSlots) return ClientSlot::ordinary;
  if (may_use_reserved && taken.regular < max_clients) return ClientSlot::reserved;
  if (taken.estop_only < kEstopOnlySlots) return ClientSlot::estop_only;
  return std::nullopt;
}

Server::Server(const DaemonConfig& config, Sequencer& sequencer)
    : config_(config), sequencer_(sequencer) {
  started_s_ = now_s();
  epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  sigset_t mask;
  sigemptyset(&mask);
  sigaddset(&mask, SIGTERM);
  sigaddset(&mask, SIGINT);
  signal_fd_ = ::signalfd(-1, &mask, SFD_NONBLOCK | SFD_CLOEXEC);
  if (epoll_fd_ < 0 || wake_fd_ < 0 || signal_fd_ < 0)
    throw std::runtime_error("cannot set up the event loop: " + errno_text());
  add_fd(wake_fd_, EPOLLIN);
  add_fd(signal_fd_, EPOLLIN);
  std::uint64_t watchdog_usec = 0;
  if (sd_watchdog_enabled(0, &watchdog_usec) > 0 && watchdog_usec > 0) {
    // Tick at half the watchdog period: a ping goes out only when both this loop and the
    // sequencer thread have moved since the previous tick.
    timer_fd_ = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    itimerspec spec{};
    const std::uint64_t half = watchdog_usec / 2;
    spec.it_interval.tv_sec = static_cast<time_t>(half / 1000000);
    spec.it_interval.tv_nsec = static_cast<long>((half % 1000000) * 1000);
    spec.it_value = spec.it_interval;
    ::timerfd_settime(timer_fd_, 0, &spec, nullptr);
    add_fd(timer_fd_, EPOLLIN);
    spdlog::info("systemd watchdog: {} ms, ticking every {} ms", watchdog_usec / 1000, half / 1000);
  }
}

Server::~Server() {
  for (auto& [fd, c] : clients_) ::close(fd);
  for (int fd : {unix_fd_, tcp_fd_, signal_fd_, wake_fd_, timer_fd_, epoll_fd_}) {
    if (fd >= 0) ::close(fd);
  }
  unlink_socket_file_if_ours();
}

void Server::remember_bound_socket_file() {
  struct stat st {};
  if (::lstat(config_.socket_path.c_str(), &st) != 0) return;
  unix_file_ours_ = true;
  unix_file_dev_ = st.st_dev;
  unix_file_ino_ = st.st_ino;
}

// Only the file this daemon bound, and only while it is still that file: a daemon that
// failed to start must leave the running one reachable.
void Server::unlink_socket_file_if_ours() const {
  if (!unix_file_ours_ || unix_from_systemd_) return;
  struct stat st {};
  if (::lstat(config_.socket_path.c_str(), &st) != 0) return;
  if (st.st_dev == unix_file_dev_ && st.st_ino == unix_file_ino_)
    ::unlink(config_.socket_path.c_str());
}

void Server::add_fd(int fd, std::uint32_t events) {
  epoll_event ev{};
  ev.events = events;
  ev.data.fd = fd;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &ev) != 0)
    throw std::runtime_error("epoll_ctl: " + errno_text());
}

void Server::open_listeners() {
  resolve_access_policy();
  open_unix_listener();
  if (config_.tcp_enabled) open_tcp_listener();
}

void Server::resolve_access_policy() {
  policy_.daemon_uid = ::geteuid();
  policy_.control_group = config_.control_group;
  if (!config_.control_group.empty()) {
    const group* g = ::getgrnam(config_.control_group.c_str());
    if (g == nullptr)
      throw ConfigError(config_.source + ": access.control_group: no group named \"" +
                        config_.control_group + "\"");
    policy_.control_gid = g->gr_gid;
    spdlog::info("stand and run commands on the Unix socket: members of group {} (gid {}) only",
                 config_.control_group, policy_.control_gid);
  }
  // Checked here too (not only when the file is read): --tcp-port can enable TCP later.
  if (config_.tcp_enabled && !is_loopback_address(config_.tcp_bind) &&
      config_.tcp_token_file.empty()) {
    throw ConfigError(config_.source + ": tcp.token_file: is required when tcp.bind (" +
                      config_.tcp_bind + ") is not a loopback address (docs/security.md)");
  }
  if (config_.tcp_enabled && !config_.tcp_token_file.empty()) {
    tcp_token_ = load_tcp_token(config_);
    policy_.tcp_token_configured = true;
  }
}

// Mode and group of the socket file, from the config, whether we bound it or systemd did:
// they decide who can connect at all.
static void apply_socket_file_access(const DaemonConfig& config, const std::string& path) {
  if (::chmod(path.c_str(), config.socket_mode) != 0) {
    throw std::runtime_error("cannot set mode " + fmt::format("{:04o}", config.socket_mode) +
                             " on " + path + ": " + errno_text());
  }
  if (!config.socket_group.empty()) {
    const group* g = ::getgrnam(config.socket_group.c_str());
    if (g == nullptr)
      throw ConfigError(config.source + ": socket.group: no group named \"" + config.socket_group +
                        "\"");
    if (::chown(path.c_str(), static_cast<uid_t>(-1), g->gr_gid) != 0) {
      throw std::runtime_error("cannot give " + path + " to group " + config.socket_group + ": " +
                               errno_text());
    }
  }
  spdlog::info("socket {}: mode {:04o}{}", path, config.socket_mode,
               config.socket_group.empty() ? std::string() : ", group " + config.socket_group);
}

void Server::open_unix_listener() {
  const int n = sd_listen_fds(1);
  for (int i = 0; i < n; ++i) {
    const int fd = SD_LISTEN_FDS_START + i;
    if (sd_is_socket_unix(fd, SOCK_STREAM, 1, nullptr, 0) > 0) {
      unix_fd_ = fd;
      unix_from_systemd_ = true;
      ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
      ::fcntl(fd, F_SETFD, FD_CLOEXEC);
      spdlog::info("listening on the socket systemd passed (socket activation)");
      sockaddr_un bound{};
      socklen_t len = sizeof bound;
      if (::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &len) == 0 &&
          bound.sun_path[0] != '\0') {
        apply_socket_file_access(config_, bound.sun_path);
      }
    }
  }
  if (unix_fd_ < 0) {
    const std::string& socket = config_.socket_path;
    socket_lock_.emplace(socket + ".lock", [&socket](const std::string& holder) {
      return "another standcald" + (holder.empty() ? std::string() : " (pid " + holder + ")") +
             " owns the socket " + socket + " (it holds " + socket + ".lock)";
    });
    remove_stale_socket(config_.socket_path);
    const sockaddr_un addr = unix_address(config_.socket_path);
    unix_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    // Created owner-only, then opened up to the configured mode: nobody outside it can
    // connect between bind() and chmod(). (No other thread runs yet.)
    const mode_t old_umask = ::umask(0177);
    const bool bound = unix_fd_ >= 0 && ::bind(unix_fd_, reinterpret_cast<const sockaddr*>(&addr),
                                               sizeof(addr)) == 0;
    ::umask(old_umask);
    if (!bound)
      throw std::runtime_error("cannot bind " + config_.socket_path + ": " + errno_text());
    remember_bound_socket_file();
    apply_socket_file_access(config_, config_.socket_path);
    if (::listen(unix_fd_, 512) != 0)
      throw std::runtime_error("cannot listen on " + config_.socket_path + ": " + errno_text());
    spdlog::info("listening on {}", config_.socket_path);
  }
  add_fd(unix_fd_, EPOLLIN);
}

void Server::open_tcp_listener() {
  const std::string where = "tcp " + config_.tcp_bind + " port " + std::to_string(config_.tcp_port);
  addrinfo hints{};
  hints.ai_flags = AI_NUMERICHOST | AI_NUMERICSERV | AI_PASSIVE;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const std::string port = std::to_string(config_.tcp_port);
  if (const int rc = ::getaddrinfo(config_.tcp_bind.c_str(), port.c_str(), &hints, &found);
      rc != 0 || found == nullptr) {
    throw std::runtime_error("cannot listen on " + where + ": " + ::gai_strerror(rc));
  }
  sockaddr_storage addr{};
  std::memcpy(&addr, found->ai_addr, found->ai_addrlen);
  socklen_t len = found->ai_addrlen;
  const int family = found->ai_family;
  ::freeaddrinfo(found);
  tcp_fd_ = ::socket(family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  const int one = 1;
  ::setsockopt(tcp_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (tcp_fd_ < 0 || ::bind(tcp_fd_, reinterpret_cast<const sockaddr*>(&addr), len) != 0 ||
      ::listen(tcp_fd_, 512) != 0 ||
      ::getsockname(tcp_fd_, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    throw std::runtime_error("cannot listen on " + where + ": " + errno_text());
  }
  tcp_port_ = ntohs(family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&addr)->sin6_port
                                       : reinterpret_cast<sockaddr_in*>(&addr)->sin_port);
  add_fd(tcp_fd_, EPOLLIN);
  const bool loopback = is_loopback_address(config_.tcp_bind);
  spdlog::info(
      "listening on tcp {}:{} ({}; control {})", config_.tcp_bind, tcp_port_,
      loopback ? "loopback" : "NOT loopback: the token travels in clear text",
      policy_.tcp_token_configured ? "after auth with the token" : "refused: no tcp.token_file");
}

void Server::post(std::function<void()> job) {
  {
    std::lock_guard lock(posted_mutex_);
    posted_.push_back(std::move(job));
  }
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof one);
}

void Server::publish(const std::string& event, const json& params) {
  post([this, event, params] {
    if (event == protocol::event::run_state) {
      sd_notifyf(0, "STATUS=run %s: %s", params.value("run_id", "").c_str(),
                 params.value("state", "").c_str());
    }
    const std::string line = protocol::make_notification(event, params);
    for (auto& [fd, c] : clients_) {
      if (c->events.count(event) || c->events.count("*")) send_line(*c, line);
    }
  });
}

void Server::run_posted() {
  std::uint64_t count = 0;
  [[maybe_unused]] const ssize_t n = ::read(wake_fd_, &count, sizeof count);
  std::vector<std::function<void()>> jobs;
  {
    std::lock_guard lock(posted_mutex_);
    jobs.swap(posted_);
  }
  for (auto& job : jobs) job();
}

void Server::watchdog_tick() {
  std::uint64_t expirations = 0;
  [[maybe_unused]] const ssize_t n = ::read(timer_fd_, &expirations, sizeof expirations);
  const std::uint64_t beat = sequencer_.heartbeat();
  if (beat != last_heartbeat_) {
    sd_notify(0, "WATCHDOG=1");
  } else {
    spdlog::warn(
        "the sequencer thread has not answered since the last watchdog tick; not pinging systemd");
  }
  last_heartbeat_ = beat;
}

void Server::run() {
  std::vector<epoll_event> events(64);
  std::vector<int> dead;
  while (running_) {
    // Asleep until an event, or until the next client timeout falls due (no polling).
    const double deadline_s = next_client_deadline_s();
    const int wait_ms =
        deadline_s < 0
            ? -1
            : static_cast<int>(std::clamp((deadline_s - now_s()) * 1000 + 1, 0.0, 3600e3));
    const int n = ::epoll_wait(epoll_fd_, events.data(), static_cast<int>(events.size()), wait_ms);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error("epoll_wait: " + errno_text());
    }
    for (int i = 0; i < n; ++i) {
      const int fd = events[i].data.fd;
      const std::uint32_t what = events[i].events;
      if (fd == unix_fd_ || fd == tcp_fd_) {
        accept_clients(fd);
      } else if (fd == signal_fd_) {
        signalfd_siginfo si{};
        while (::read(signal_fd_, &si, sizeof si) == sizeof si) {
          spdlog::info("received signal {}: shutting down", si.ssi_signo);
          running_ = false;
        }
      } else if (fd == wake_fd_) {
        run_posted();
      } else if (fd == timer_fd_) {
        watchdog_tick();
      } else {
        auto it = clients_.find(fd);
        if (it == clients_.end()) continue;
        Client& c = *it->second;
        if (what & EPOLLIN) read_client(c);
        if ((what & EPOLLOUT) && c.fd >= 0) flush(c);
        if ((what & (EPOLLHUP | EPOLLERR)) && !(what & EPOLLIN) && c.fd >= 0) c.fd = -1;
      }
    }
    close_expired_clients();
    // Close the clients marked dead (fd = -1) during this round.
    for (auto it = clients_.begin(); it != clients_.end();) {
      if (it->second->fd < 0) {
        ::close(it->first);
        it = clients_.erase(it);
      } else {
        ++it;
      }
    }
  }
}

void Server::accept_clients(int listen_fd) {
  for (;;) {
    const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) spdlog::warn("accept: {}", errno_text());
      return;
    }
    Peer peer = listen_fd == tcp_fd_ ? tcp_peer(fd) : unix_peer(fd);
    const auto slot = slot_for_new_client(slots_taken(), config_.max_clients,
                                          may_use_reserved_slot(peer, policy_));
    if (!slot) {
      refuse_connection(fd);
      continue;
    }
    auto c = std::make_unique<Client>();
    c->fd = fd;
    c->serial = next_serial_++;
    c->peer = std::move(peer);
    c->slot = *slot;
    c->connected_s = c->last_activity_s = now_s();
    add_fd(fd, EPOLLIN | EPOLLRDHUP);
    Client& ref = *c;
    clients_[fd] = std::move(c);
    greet(ref);
  }
}

SlotsTaken Server::slots_taken() const {
  SlotsTaken taken;
  for (const auto& [fd, c] : clients_) {
    if (c->fd < 0) continue;  // closing this round
    (c->slot == ClientSlot::estop_only ? taken.estop_only : taken.regular) += 1;
  }
  return taken;
}

// Answer and close at once: never leave a connection hanging.
void Server::refuse_connection(int fd) {
  const std::string line =
      protocol::make_error(
          nullptr, static_cast<int>(ErrorCode::too_many_clients),
          "standcald already serves " + std::to_string(config_.max_clients) +
              " clients (the limit) and its estop-only slots are taken; try again later") +
      "\n";
  [[maybe_unused]] const ssize_t n =
      ::send(fd, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::close(fd);
  ++dropped_clients_;
}

void Server::greet(Client& c) {
  protocol::Hello hello;
  hello.version = kVersion;
  hello.protocol = protocol::kProtocolVersion;
  hello.max_request_bytes = static_cast<std::int64_t>(protocol::kMaxRequestBytes);
  if (c.slot == ClientSlot::estop_only) {
    hello.estop_only = true;
    hello.message = "standcald serves " + std::to_string(config_.max_clients) +
                    " clients (the limit): this connection may send one estop, nothing else";
    spdlog::warn("connection limit reached: {} got an estop-only slot", describe_peer(c.peer));
  } else if (c.slot == ClientSlot::reserved) {
    spdlog::info("connection limit nearly reached: {} got a reserved slot", describe_peer(c.peer));
  }
  send_line(c, protocol::make_notification(m::hello, hello));
}

void Server::read_client(Client& c) {
  char buf[65536];
  // A bounded amount per wake-up, so one busy client cannot starve the others.
  for (int round = 0; round < 4 && c.fd >= 0; ++round) {
    const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
    if (n == 0) {
      c.fd = -1;  // closed by the client
      return;
    }
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) c.fd = -1;
      return;
    }
    c.in.append(std::string_view(buf, static_cast<std::size_t>(n)));
    bool oversized = false;
    while (c.fd >= 0) {
      auto line = c.in.next_line();
      if (!line) break;
      if (line->size() > protocol::kMaxRequestBytes) {
        oversized = true;
        break;
      }
      handle_line(c, *line);
    }
    track_partial_request(c);
    if (c.fd >= 0 && (oversized || c.in.overflowed())) {
      send_line(c, protocol::make_error(nullptr, static_cast<int>(ErrorCode::invalid_request),
                                        "request longer than " +
                                            std::to_string(protocol::kMaxRequestBytes) +
                                            " bytes; closing the connection"));
      spdlog::warn("client sent a request longer than {} bytes; closed",
                   protocol::kMaxRequestBytes);
      if (c.fd >= 0) {
        ::shutdown(c.fd, SHUT_WR);
        c.fd = -1;
      }
      ++dropped_clients_;
      return;
    }
    if (static_cast<std::size_t>(n) < sizeof buf) return;
  }
}

// The methods the socket thread answers itself (method_table.hpp: executor server).
const Server::Binding Server::kBindings[] = {
    {m::status, &Server::status_view},         {m::run_status, &Server::run_status_view},
    {m::run_result, &Server::run_result_view}, {m::runs_list, &Server::runs_list_view},
    {m::subscribe, &Server::subscribe},        {m::auth, &Server::authenticate},
};

std::vector<std::string_view> Server::answered_methods() {
  std::vector<std::string_view> names;
  for (const Binding& b : kBindings) names.push_back(b.method);
  return names;
}

json Server::answer_here(Client& c, const protocol::Request& req) {
  for (const Binding& b : kBindings)
    if (b.method == req.method) return (this->*b.answer)(c, req.params);
  throw std::logic_error("method_table.cpp routes " + req.method +
                         " to the socket thread, which has no handler for it");
}

json Server::status_view(Client& c, const json& params) {
  protocol::parse_no_params(params, m::status);
  return status(c);
}

json Server::run_status_view(Client&, const json& params) {
  return sequencer_.run_status(
      protocol::RunTargetParams::parse(params, m::run_status).run_id.value_or(""));
}

json Server::run_result_view(Client&, const json& params) {
  return sequencer_.run_result(protocol::RunResultParams::parse(params).run_id);
}

json Server::runs_list_view(Client&, const json& params) {
  return sequencer_.runs_list(runs_list_query(protocol::RunsListParams::parse(params)));
}

// A method another thread answers: the diagnosis worker (run.diagnose, diagnose_job.hpp)
// or the sequencer; the answer comes back through post() to this client, if still there.
void Server::hand_on(Client& c, const protocol::Request& req, Executor executor) {
  const std::uint64_t serial = c.serial;
  const int fd = c.fd;
  const json id = req.id;
  const bool notification = req.is_notification;
  if (!notification) ++c.pending_replies;
  ReplyFn reply = [this, serial, fd, id, notification](Outcome o) {
    if (notification) return;
    post([this, serial, fd, id, o = std::move(o)] { reply_later(serial, fd, id, o); });
  };
  if (executor == Executor::diagnose_worker) {
    diagnose_jobs_.submit(sequencer_, req.params, std::move(reply));
  } else {
    sequencer_.submit(req.method, req.params, std::move(reply), describe_peer_process(c.peer));
  }
}

void Server::handle_line(Client& c, const std::string& line) {
  if (line.find_first_not_of(" \t\r") == std::string::npos) return;  // blank lines are ignored
  ++requests_;
  auto parsed = protocol::parse_request(line);
  if (auto* bad = std::get_if<protocol::BadRequest>(&parsed)) {
    send_line(c, protocol::make_error(bad->id, bad->error.code(), bad->error.what()));
    return;
  }
  protocol::Request& req = std::get<protocol::Request>(parsed);
  c.last_activity_s = now_s();
  if (refuse_on_estop_only_slot(c, req)) return;
  try {
    if (req.positional_params) {
      throw RpcError(ErrorCode::invalid_params,
                     req.method +
                         ": \"params\" must be an object of named parameters "
                         "(no standcald method takes positional ones)");
    }
    // A name standcald does not have is said so to anyone (docs/protocol.md lists them all);
    // the access rule is for the methods it has.
    const MethodSpec* spec = find_method(req.method);
    if (spec == nullptr) {
      throw RpcError(ErrorCode::method_not_found,
                     "unknown method \"" + req.method + "\" (see docs/protocol.md)");
    }
    if (auto refusal = refuse_control(req.method, c.peer, policy_)) {
      spdlog::info("refused {} from {}", protocol::printable(req.method), describe_peer(c.peer));
      throw RpcError(ErrorCode::not_permitted, *refusal);
    }
    if (spec->executor != Executor::server) {
      hand_on(c, req, spec->executor);
      return;
    }
    const json result = answer_here(c, req);
    if (!req.is_notification) send_line(c, protocol::make_result(req.id, result));
  } catch (const RpcError& e) {
    if (!req.is_notification)
      send_line(c, protocol::make_error(req.id, e.code(), e.what(), e.data()));
  } catch (const std::exception& e) {
    if (!req.is_notification)
      send_line(
          c, protocol::make_error(req.id, static_cast<int>(ErrorCode::internal_error), e.what()));
  }
  if (c.close_after_reply && c.fd >= 0) {
    ::shutdown(c.fd, SHUT_WR);
    c.fd = -1;
  }
}

void Server::reply_later(std::uint64_t serial, int fd, const json& id, Outcome o) {
  auto it = clients_.find(fd);
  if (it == clients_.end() || it->second->serial != serial || it->second->fd < 0)
    return;  // client gone
  Client& c = *it->second;
  send_line(c, o.error_code == 0 ? protocol::make_result(id, o.result)
                                 : protocol::make_error(id, o.error_code, o.error_message));
  c.pending_replies = std::max(0, c.pending_replies - 1);
  c.last_activity_s = now_s();
  if (c.slot == ClientSlot::estop_only && c.fd >= 0) {
    ::shutdown(c.fd, SHUT_WR);  // its one estop is answered: the slot is free again
    c.fd = -1;
  }
}

// A connection past max_clients may send `estop` and nothing else.
bool Server::refuse_on_estop_only_slot(Client& c, const protocol::Request& req) {
  if (c.slot != ClientSlot::estop_only || req.method == m::estop) return false;
  close_with_error(c, static_cast<int>(ErrorCode::too_many_clients),
                   "standcald serves " + std::to_string(config_.max_clients) +
                       " clients (the limit): this connection may only send estop; try again later",
                   req.id);
  return true;
}

void Server::track_partial_request(Client& c) {
  if (c.in.pending_bytes() == 0) {
    c.partial_since_s = -1;
  } else if (c.partial_since_s < 0) {
    c.partial_since_s = now_s();
  }
}

double Server::client_deadline_s(const Client& c) const {
  double due = -1;
  auto earliest = [&due](double t) { due = due < 0 ? t : std::min(due, t); };
  // An estop-only connection lives one request timeout at most.
  if (c.slot == ClientSlot::estop_only) earliest(c.connected_s + config_.client_request_timeout_s);
  if (c.partial_since_s >= 0) earliest(c.partial_since_s + config_.client_request_timeout_s);
  // Waiting for an answer or for events is not idleness.
  if (c.pending_replies == 0 && c.events.empty())
    earliest(c.last_activity_s + config_.client_idle_timeout_s);
  return due;
}

double Server::next_client_deadline_s() const {
  double due = -1;
  for (const auto& [fd, c] : clients_) {
    if (c->fd < 0) continue;
    const double t = client_deadline_s(*c);
    if (t >= 0 && (due < 0 || t < due)) due = t;
  }
  return due;
}

void Server::close_expired_clients() {
  const double now = now_s();
  for (auto& [fd, c] : clients_) {
    if (c->fd < 0) continue;
    const double due = client_deadline_s(*c);
    if (due < 0 || due > now) continue;
    const bool partial =
        c->partial_since_s >= 0 && c->partial_since_s + config_.client_request_timeout_s <= now;
    const std::string why =
        partial || c->slot == ClientSlot::estop_only
            ? fmt::format("request not completed within {} s (client_request_timeout_s)",
                          config_.client_request_timeout_s)
            : fmt::format(
                  "idle for {} s (client_idle_timeout_s) with no request, answer pending or "
                  "subscription",
                  config_.client_idle_timeout_s);
    spdlog::info("closed {}: {}", describe_peer(c->peer), why);
    close_with_error(*c, static_cast<int>(ErrorCode::invalid_request),
                     why + "; closing the connection");
  }
}

void Server::close_with_error(Client& c, int code, const std::string& message, const json& id) {
  send_line(c, protocol::make_error(id, code, message));
  if (c.fd >= 0) {
    ::shutdown(c.fd, SHUT_WR);
    c.fd = -1;
  }
  ++dropped_clients_;
}

json Server::subscribe(Client& c, const json& params) {
  const auto request = protocol::SubscribeParams::parse(params);
  std::set<std::string> wanted;
  if (!request.events) wanted.insert("*");
  for (const std::string& name : request.events.value_or(std::vector<std::string>{})) {
    if (name != "*" && !known_events().count(name))
      throw RpcError(ErrorCode::invalid_params, "subscribe: unknown event \"" + name + "\"");
    wanted.insert(name);
  }
  c.events = wanted;
  protocol::SubscribedResult answer;
  if (wanted.count("*")) {
    answer.events.assign(known_events().begin(), known_events().end());
  } else {
    answer.events.assign(wanted.begin(), wanted.end());
  }
  return answer;
}

// `auth {token}`: a TCP client asks for control. A wrong token closes the connection, so
// every guess costs a new connection (and a log line naming the address).
json Server::authenticate(Client& c, const json& params) {
  const std::string token = protocol::AuthParams::parse(params).token;
  if (!c.peer.tcp) {
    throw RpcError(
        ErrorCode::invalid_state,
        "auth: only TCP clients authenticate; on the Unix socket your user and groups decide");
  }
  if (!policy_.tcp_token_configured) {
    throw RpcError(
        ErrorCode::not_permitted,
        "auth: this daemon has no tcp.token_file, so TCP clients may only read and send estop");
  }
  if (!tokens_equal(token, tcp_token_)) {
    spdlog::warn("auth: wrong token from {}; connection closed", describe_peer(c.peer));
    c.close_after_reply = true;  // handle_line closes it once the error line is sent
    throw RpcError(ErrorCode::not_permitted, "auth: wrong token; closing the connection");
  }
  c.peer.token_accepted = true;
  spdlog::info("auth: {} may now command the stand and runs", describe_peer(c.peer));
  return protocol::AuthResult{true};
}

json Server::status(const Client& c) const {
  protocol::StatusResult s = sequencer_.status();
  protocol::DaemonInfo& d = s.daemon;
  d.version = kVersion;
  d.protocol = protocol::kProtocolVersion;
  d.uptime_s = now_s() - started_s_;
  d.clients = static_cast<std::int64_t>(clients_.size());
  d.max_clients = config_.max_clients;
  d.requests = static_cast<std::int64_t>(requests_);
  d.dropped_clients = static_cast<std::int64_t>(dropped_clients_);
  d.state_dir = config_.state_dir;
  d.socket = config_.socket_path;
  if (tcp_port_ > 0) d.tcp_port = tcp_port_;
  // What this connection may do, so an operator can check their rights without moving anything.
  if (!policy_.control_group.empty()) d.access.control_group = policy_.control_group;
  d.access.tcp_token = policy_.tcp_token_configured;
  d.access.peer = describe_peer(c.peer);
  d.access.control = !refuse_control(m::stand_move, c.peer, policy_).has_value();
  return s;
}

void Server::send_line(Client& c, const std::string& line) {
  if (c.fd < 0) return;
  c.out += line;
  c.out += '\n';
  flush(c);
  if (c.fd >= 0 && c.out.size() > config_.client_queue_bytes) {
    // Never wait for a slow reader: it loses its connection, nobody else waits.
    spdlog::warn("dropped {}: it stopped reading ({} bytes unsent, limit client_queue_bytes {})",
                 describe_peer(c.peer), c.out.size(), config_.client_queue_bytes);
    ++dropped_clients_;
    c.fd = -1;
  }
}

void Server::flush(Client& c) {
  std::size_t sent = 0;
  while (sent < c.out.size()) {
    const ssize_t n =
        ::send(c.fd, c.out.data() + sent, c.out.size() - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) {
        c.fd = -1;
        return;
      }
      break;
    }
    sent += static_cast<std::size_t>(n);
  }
  c.out.erase(0, sent);
  const bool want = !c.out.empty();
  if (want != c.want_write) {
    epoll_event ev{};
    ev.events = EPOLLIN | EPOLLRDHUP | (want ? EPOLLOUT : 0u);
    ev.data.fd = c.fd;
    ::epoll_ctl(epoll_fd_, EPOLL_CTL_MOD, c.fd, &ev);
    c.want_write = want;
  }
}

}  // namespace standcal::daemon
