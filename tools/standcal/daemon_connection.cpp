#include "tools/standcal/daemon_connection.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "protocol/jsonrpc/client.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/messages.hpp"
#include "protocol/jsonrpc/methods.hpp"
#include "protocol/jsonrpc/paths.hpp"

namespace standcal::cli {

using nlohmann::json;

namespace {

std::string octal_mode(mode_t mode) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(mode & 07777));
  return buf;
}

// The whole file through one descriptor, so the checked file is the one read.
std::string read_checked_token_file(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    throw std::runtime_error("cannot open the token file " + path + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw std::runtime_error("the token file " + path + " is not a regular file");
  }
  if ((st.st_mode & 077) != 0) {
    ::close(fd);
    throw std::runtime_error(
        "the token file " + path + " has mode " + octal_mode(st.st_mode) +
        ": group or others may access it, and it holds the daemon's control secret; "
        "`chmod 600 " +
        path + "` (and ask whether someone else has read it)");
  }
  std::string text;
  char buf[4096];
  ssize_t n = 0;
  while ((n = ::read(fd, buf, sizeof buf)) > 0) text.append(buf, static_cast<std::size_t>(n));
  const int read_errno = errno;
  ::close(fd);
  if (n < 0)
    throw std::runtime_error("cannot read the token file " + path + ": " +
                             std::strerror(read_errno));
  return text;
}

DaemonOptions& global_options() {
  static DaemonOptions options;
  return options;
}

// The command's options, with the global ones where the command named no endpoint.
DaemonOptions effective(const DaemonOptions& o) {
  DaemonOptions e = o;
  const DaemonOptions& g = global_options();
  if (e.tcp.empty() && e.socket.empty()) {
    e.tcp = g.tcp;
    e.socket = g.socket;
  }
  if (e.token_file.empty()) e.token_file = g.token_file;
  if (!e.token_file.empty() && e.tcp.empty())
    throw std::runtime_error("--token-file " + e.token_file +
                             " needs --tcp: the Unix socket authenticates by the caller's groups");
  return e;
}

}  // namespace

void add_global_daemon_options(CLI::App& app) {
  DaemonOptions& g = global_options();
  auto* socket =
      app.add_option("--socket", g.socket, "standcald's socket, for every daemon command");
  auto* tcp = app.add_option("--tcp", g.tcp,
                             "reach standcald over TCP at HOST:PORT, for every daemon command");
  // No needs(tcp) here: the --tcp may be the command's own (effective() checks the pair).
  auto* token = app.add_option("--token-file", g.token_file,
                               "with --tcp: authenticate with the token in FILE");
  tcp->excludes(socket);
  // Runs before the command: a global option given to a command that takes no daemon
  // endpoint (`standcal --tcp H:P fit rec.csv`; doctor reads its config's) is a usage
  // error, not silently dropped.
  app.parse_complete_callback([&app, socket, tcp, token] {
    const CLI::App* command = &app;
    std::string path;  // "stand status", not just "status"
    while (!command->get_subcommands().empty()) {
      command = command->get_subcommands().front();
      path += (path.empty() ? "" : " ") + command->get_name();
    }
    if (command->get_option_no_throw("--tcp") != nullptr) return;
    for (const CLI::Option* given : {socket, tcp, token})
      if (given->count() > 0)
        throw CLI::ValidationError(
            given->get_name(), "`" + path +
                                   "` does not take it: it names standcald's endpoint for "
                                   "the commands that talk to the daemon (status, run, runs, ...)");
  });
}

void add_daemon_options(CLI::App* cmd, DaemonOptions& o) {
  auto* socket = cmd->add_option(
      "--socket", o.socket,
      "standcald's socket (default: the config's, else /run/standcal/standcald.sock)");
  auto* tcp = cmd->add_option("--tcp", o.tcp,
                              "reach standcald over TCP at HOST:PORT (IPv4) instead of its socket");
  cmd->add_option("--token-file", o.token_file,
                  "with --tcp: send the token in FILE (mode 0600) with `auth` first, to command "
                  "the stand and runs")
      ->needs(tcp);
  tcp->excludes(socket);
  cmd->add_option("--config", o.config, "read the socket path from this standcald config file");
  cmd->add_flag("--json", o.json, "machine-readable output");
}

// --tcp HOST:PORT, checked whole before anything connects: a numeric IPv4 address and a
// port from 1 to 65535 (the token must never go to a port the operator did not name).
std::string tcp_endpoint(const std::string& option_value) {
  const std::string host_port =
      option_value.rfind("tcp://", 0) == 0 ? option_value.substr(6) : option_value;
  const auto bad = [&](const std::string& why) {
    return std::runtime_error("--tcp '" + option_value + "': " + why +
                              " (expected HOST:PORT, e.g. 127.0.0.1:4871)");
  };
  const auto colon = host_port.rfind(':');
  if (colon == std::string::npos) throw bad("no port");
  in_addr ignored{};
  const std::string host = host_port.substr(0, colon);
  if (::inet_pton(AF_INET, host.c_str(), &ignored) != 1)
    throw bad("'" + host + "' is not a numeric IPv4 address");
  const std::string port = host_port.substr(colon + 1);
  if (!protocol::parse_tcp_port(port))
    throw bad("the port '" + port + "' is not a whole number from 1 to 65535");
  return "tcp://" + host_port;
}

// The endpoint of options the global ones are already merged into (effective()).
static std::string endpoint_of(const DaemonOptions& o) {
  if (!o.tcp.empty()) return tcp_endpoint(o.tcp);
  if (!o.socket.empty()) return o.socket;
  if (!o.config.empty()) {
    std::error_code ec;
    if (std::filesystem::is_directory(o.config, ec))
      throw std::runtime_error("--config " + o.config +
                               ": is a directory, not a standcald config file");
    std::ifstream in(o.config);
    const json doc = json::parse(in, nullptr, false);
    if (!in || doc.is_discarded()) throw std::runtime_error("cannot read the config " + o.config);
    if (doc.contains("socket") && doc["socket"].contains("path"))
      return doc["socket"]["path"].get<std::string>();
  }
  if (const char* env = std::getenv("STANDCAL_SOCKET")) return env;
  return paths::kSocket;
}

std::string daemon_endpoint(const DaemonOptions& given) { return endpoint_of(effective(given)); }

std::string read_token_file(const std::string& path) {
  const std::string text = read_checked_token_file(path);
  // The first line, trimmed at the end as standcald trims it (config.cpp load_tcp_token).
  std::string token = text.substr(0, text.find('\n'));
  while (!token.empty() && (token.back() == '\r' || token.back() == ' ' || token.back() == '\t'))
    token.pop_back();
  if (token.empty())
    throw std::runtime_error("the token file " + path +
                             " is empty: its first line must be the token");
  return token;
}

std::unique_ptr<protocol::Client> connect_daemon(const DaemonOptions& given,
                                                 std::chrono::milliseconds timeout) {
  // Check the endpoint and read the token before connecting: a bad file must not cost a
  // connection, and a bad --tcp must not send the token anywhere.
  const DaemonOptions o = effective(given);
  const std::string endpoint = endpoint_of(o);
  const std::string token = o.token_file.empty() ? std::string() : read_token_file(o.token_file);
  auto client = std::make_unique<protocol::Client>(endpoint, timeout);
  if (token.empty()) return client;
  try {
    client->call(protocol::method::auth, protocol::AuthParams{token}, timeout);
  } catch (const protocol::RpcError& e) {
    throw std::runtime_error("standcald at " + endpoint + " refused the token from " +
                             o.token_file + ": " + e.what() + " (" +
                             protocol::error_code_name(e.code()) +
                             "); the file must hold the daemon's tcp.token_file token");
  }
  return client;
}

}  // namespace standcal::cli
