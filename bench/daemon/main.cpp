// standcal-bench-daemon [--clients N] [--requests M] [--time-scale K]
// Starts a real standcald on the simulated backend in a temporary directory and prints:
//  - `status` round-trip latency p50/p99 with N concurrent clients (target p99 < 5 ms);
//  - RSS and CPU of the daemon idle (target ≈ 0: no busy polling) and during a paper9
//    run (target RSS < 30 MB).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "protocol/jsonrpc/client.hpp"

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

struct ProcessUsage {
  double cpu_s = 0;  // user + system
  double rss_mb = 0;
};

ProcessUsage usage_of(pid_t pid) {
  ProcessUsage u;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(stat, line);
  std::istringstream fields(line.substr(line.rfind(')') + 2));
  std::string f;
  for (int i = 3; i <= 15 && fields >> f; ++i) {
    if (i == 14) u.cpu_s += std::stod(f) / static_cast<double>(sysconf(_SC_CLK_TCK));
    if (i == 15) u.cpu_s += std::stod(f) / static_cast<double>(sysconf(_SC_CLK_TCK));
  }
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) u.rss_mb = std::stod(line.substr(6)) / 1024.0;
  }
  return u;
}

// CPU share (% of one core) and peak RSS over `seconds`.
std::pair<double, double> measure(pid_t pid, double seconds) {
  const ProcessUsage a = usage_of(pid);
  const auto t0 = Clock::now();
  double rss_peak = a.rss_mb;
  while (Clock::now() - t0 < std::chrono::duration<double>(seconds)) {
    std::this_thread::sleep_for(100ms);
    rss_peak = std::max(rss_peak, usage_of(pid).rss_mb);
  }
  const ProcessUsage b = usage_of(pid);
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  return {100.0 * (b.cpu_s - a.cpu_s) / wall, rss_peak};
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}

std::vector<double> status_latencies(const std::string& socket, int clients, int requests) {
  std::vector<std::vector<double>> per(static_cast<std::size_t>(clients));
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      standcal::protocol::Client client(socket);
      for (int i = 0; i < requests; ++i) {
        const auto t0 = Clock::now();
        client.call("status");
        per[static_cast<std::size_t>(c)].push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      }
    });
  }
  for (auto& t : threads) t.join();
  std::vector<double> all;
  for (auto& v : per) all.insert(all.end(), v.begin(), v.end());
  return all;
}

}  // namespace

int main(int argc, char** argv) {
  int clients = 32, requests = 300;
  double time_scale = 20;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--clients") clients = std::atoi(argv[i + 1]);
    if (a == "--requests") requests = std::atoi(argv[i + 1]);
    if (a == "--time-scale") time_scale = std::atof(argv[i + 1]);
  }
  std::string dir = (std::filesystem::temp_directory_path() / "standcal-bench-XXXXXX").string();
  if (::mkdtemp(dir.data()) == nullptr) return 1;
  const std::string socket = dir + "/standcald.sock";
  const pid_t pid = ::fork();
  if (pid == 0) {
    const std::string log = dir + "/standcald.log";
    std::freopen(log.c_str(), "w", stderr);
    const std::string ts = std::to_string(time_scale);
    ::execl(STANDCALD_PATH, STANDCALD_PATH, "--sim", "--socket", socket.c_str(), "--state-dir",
            (dir + "/state").c_str(), "--time-scale", ts.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  int rc = 0;
  try {
    for (int i = 0;; ++i) {
      try {
        standcal::protocol::Client probe(socket);
        break;
      } catch (const std::exception&) {
        if (i > 500) throw;
        std::this_thread::sleep_for(20ms);
      }
    }
    std::this_thread::sleep_for(500ms);
    const auto [idle_cpu, idle_rss] = measure(pid, 3.0);
    std::printf("idle:        CPU %.2f %% of one core, RSS %.1f MB (3 s)\n", idle_cpu, idle_rss);

    auto lat = status_latencies(socket, clients, requests);
    std::printf("status idle: %d clients x %d requests: p50 %.3f ms, p99 %.3f ms, max %.3f ms\n",
                clients, requests, percentile(lat, 0.5), percentile(lat, 0.99),
                percentile(lat, 1.0));

    standcal::protocol::Client c(socket);
    const auto run =
        c.call("run.start", {{"program", "paper9"}, {"unit_serial", "BENCH"}, {"dwell_s", 60}});
    std::this_thread::sleep_for(300ms);
    const auto [run_cpu, run_rss] = measure(pid, 2.0);
    std::printf("during run:  CPU %.2f %% of one core, peak RSS %.1f MB (time x%.0f)\n", run_cpu,
                run_rss, time_scale);
    lat = status_latencies(socket, clients, requests);
    std::printf("status in run: %d clients x %d requests: p50 %.3f ms, p99 %.3f ms, max %.3f ms\n",
                clients, requests, percentile(lat, 0.5), percentile(lat, 0.99),
                percentile(lat, 1.0));
    for (;;) {
      const auto s = c.call("run.status", {{"run_id", run["run_id"]}});
      const std::string st = s["state"];
      if (st != "running") {
        std::printf("run ended %s; peak RSS after the fit %.1f MB\n", st.c_str(),
                    usage_of(pid).rss_mb);
        break;
      }
      std::this_thread::sleep_for(200ms);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench: %s\n", e.what());
    rc = 1;
  }
  ::kill(pid, SIGTERM);
  ::waitpid(pid, nullptr, 0);
  std::filesystem::remove_all(dir);
  return rc;
}
