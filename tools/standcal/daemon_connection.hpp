#pragma once
// How `standcal` reaches standcald (docs/security.md): the Unix socket by default, or TCP
// with --tcp; over TCP, --token-file sends the daemon's token with `auth` first so the
// connection may command the stand and runs. Shared by every daemon command group.
#include <CLI/CLI.hpp>
#include <chrono>
#include <memory>
#include <string>

#include "protocol/jsonrpc/client.hpp"

namespace standcal::cli {

struct DaemonOptions {
  std::string socket;      // Unix socket path
  std::string tcp;         // "HOST:PORT" or "tcp://HOST:PORT"; empty: the Unix socket
  std::string token_file;  // TCP only: the token to send with `auth`
  std::string config;      // read the socket path from a standcald config
  bool json = false;
};

// --socket, --tcp, --token-file, --config, --json.
void add_daemon_options(CLI::App* cmd, DaemonOptions& o);

// --socket, --tcp and --token-file before the command (`standcal --tcp HOST:PORT
// --token-file F run start ...`, as docs/protocol.md writes it); a command's own
// --socket or --tcp wins over these (and they over its --config), and its --token-file
// over this one.
void add_global_daemon_options(CLI::App& app);

// "tcp://HOST:PORT" for --tcp, else the socket path (--socket, the config's,
// $STANDCAL_SOCKET, /run/standcal/standcald.sock). The global options fill what the
// command's options leave empty.
std::string daemon_endpoint(const DaemonOptions& o);

// The token in `path`: its first line without trailing whitespace. Refuses, like ssh
// does for private keys, a file that group or others may access (any of mode 077), a
// file that is not a regular file, and an empty one; throws naming the file and the fix.
std::string read_token_file(const std::string& path);

// Connects and, with --token-file, authenticates; throws std::runtime_error with a
// one-line reason (a refused token names the endpoint and the file).
std::unique_ptr<protocol::Client> connect_daemon(
    const DaemonOptions& o, std::chrono::milliseconds timeout = std::chrono::seconds(10));

}  // namespace standcal::cli
