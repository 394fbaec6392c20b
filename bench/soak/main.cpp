// standcal-bench-soak [--minutes M] [--time-scale K] [--dwell-s D] [--sample-s S]
// Starts a real standcald on the simulated backend in a temporary directory and runs
// paper9 back to back for M minutes (default 30). Each run is followed by a fresh
// subscriber connection, a few requesters and the run's result, so every connection
// path opens and closes. Every S seconds it prints the daemon's RSS (/proc/PID/status)
// and open fd count (/proc/PID/fd); at the end the first, last and peak values and the
// RSS trend over the second half (a leak shows as a steady slope; flat is the target).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "protocol/jsonrpc/client.hpp"

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using nlohmann::json;
using standcal::protocol::Client;

namespace {

struct Sample {
  double t_min = 0;
  int runs = 0;
  long rss_kb = 0;
  long fds = 0;
};

long rss_kb_of(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

long open_fds_of(pid_t pid) {
  std::error_code ec;
  long n = 0;
  for (auto it = std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec);
       !ec && it != std::filesystem::directory_iterator(); it.increment(ec)) {
    ++n;
  }
  return ec ? -1 : n;
}

// Least-squares slope of RSS (kB per minute) over the samples given.
double rss_slope_kb_per_min(const std::vector<Sample>& s) {
  if (s.size() < 2) return 0;
  double mt = 0, mr = 0;
  for (const auto& x : s) mt += x.t_min, mr += static_cast<double>(x.rss_kb);
  mt /= static_cast<double>(s.size());
  mr /= static_cast<double>(s.size());
  double num = 0, den = 0;
  for (const auto& x : s) {
    num += (x.t_min - mt) * (static_cast<double>(x.rss_kb) - mr);
    den += (x.t_min - mt) * (x.t_min - mt);
  }
  return den > 0 ? num / den : 0;
}

pid_t start_daemon(const std::string& dir, double time_scale) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const std::string log = dir + "/standcald.log";
    if (std::freopen(log.c_str(), "w", stderr) == nullptr) ::_exit(126);
    const std::string ts = std::to_string(time_scale);
    const std::string socket = dir + "/standcald.sock";
    const std::string state = dir + "/state";
    ::execl(STANDCALD_PATH, STANDCALD_PATH, "--sim", "--socket", socket.c_str(), "--state-dir", state.c_str(),
            "--time-scale", ts.c_str(), "--log-level", "warn", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  return pid;
}

// One run with a subscriber following it and requesters asking meanwhile; closes them all.
std::string one_run(const std::string& socket, int index, double dwell_s) {
  Client control(socket);
  Client subscriber(socket);
  subscriber.call("subscribe", {{"events", "all"}});
  const std::string run_id = control.call("run.start", {{"program", "paper9"},
                                                         {"unit_serial", "SOAK-" + std::to_string(index % 5)},
                                                         {"dwell_s", dwell_s},
                                                         {"settle_s", 1}})["run_id"];
  std::string state = "running";
  const auto deadline = Clock::now() + 10min;
  while (Clock::now() < deadline) {
    auto n = subscriber.next_notification(1s);
    if (n && (*n)["method"] == "run.state" && (*n)["params"]["state"] != "running") {
      state = (*n)["params"]["state"];
      break;
    }
    Client requester(socket);  // a short-lived connection each time
    requester.call("status");
    requester.call("run.status", {{"run_id", run_id}});
  }
  if (state == "done") control.call("run.result", {{"run_id", run_id}});
  control.call("runs.list");
  return state;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"standcal-bench-soak: back-to-back simulated runs, printing the daemon's RSS and open fds"};
  double minutes = 30, time_scale = 200, dwell_s = 10, sample_s = 10;
  app.add_option("--minutes", minutes, "how long to run (default 30)")->check(CLI::Range(0.1, 24 * 60.0));
  app.add_option("--time-scale", time_scale, "simulated time runs this many times faster (default 200)")
      ->check(CLI::Range(1.0, 10000.0));
  app.add_option("--dwell-s", dwell_s, "dwell per position, simulated seconds (default 10)")->check(CLI::Range(0.5, 600.0));
  app.add_option("--sample-s", sample_s, "seconds between samples (default 10)")->check(CLI::Range(0.5, 600.0));
  CLI11_PARSE(app, argc, argv);

  std::string dir = (std::filesystem::temp_directory_path() / "standcal-soak-XXXXXX").string();
  if (::mkdtemp(dir.data()) == nullptr) return 1;
  const std::string socket = dir + "/standcald.sock";
  const pid_t pid = start_daemon(dir, time_scale);
  int rc = 0;
  std::vector<Sample> samples;
  try {
    for (int i = 0;; ++i) {
      try {
        Client probe(socket);
        break;
      } catch (const std::exception&) {
        if (i > 500) throw;
        std::this_thread::sleep_for(20ms);
      }
    }
    std::printf("soak: standcald pid %d, paper9 dwell %.1f s at time x%.0f, %.1f min, sample every %.1f s\n", pid,
                dwell_s, time_scale, minutes, sample_s);
    std::printf("%8s %6s %10s %6s\n", "t_min", "runs", "rss_kb", "fds");
    const auto t0 = Clock::now();
    const auto end = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::ratio<60>>(minutes));
    const auto sample_period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(sample_s));
    auto next_sample = t0;
    int runs = 0, not_done = 0;
    auto sample = [&] {
      Sample s{std::chrono::duration<double, std::ratio<60>>(Clock::now() - t0).count(), runs, rss_kb_of(pid),
               open_fds_of(pid)};
      samples.push_back(s);
      std::printf("%8.2f %6d %10ld %6ld\n", s.t_min, s.runs, s.rss_kb, s.fds);
      std::fflush(stdout);
    };
    sample();
    next_sample += sample_period;
    // Samples are taken between runs too, on a thread of their own, so a long run does
    // not hide a growth inside it.
    std::atomic<bool> stop{false};
    std::mutex sample_mutex;
    std::thread sampler([&] {
      while (!stop) {
        std::this_thread::sleep_for(100ms);
        if (Clock::now() >= next_sample) {
          std::lock_guard lock(sample_mutex);
          sample();
          next_sample += sample_period;
        }
      }
    });
    try {
      while (Clock::now() < end) {
        const std::string state = one_run(socket, runs, dwell_s);
        std::lock_guard lock(sample_mutex);
        ++runs;
        if (state != "done") {
          ++not_done;
          std::printf("run %d ended %s\n", runs, state.c_str());
        }
      }
    } catch (...) {
      stop = true;
      sampler.join();
      throw;
    }
    stop = true;
    sampler.join();
    sample();
    const auto [rss_min, rss_max] = std::minmax_element(samples.begin(), samples.end(),
                                                        [](const Sample& a, const Sample& b) { return a.rss_kb < b.rss_kb; });
    const auto fds_max = std::max_element(samples.begin(), samples.end(),
                                          [](const Sample& a, const Sample& b) { return a.fds < b.fds; });
    const std::vector<Sample> second_half(samples.begin() + static_cast<long>(samples.size() / 2), samples.end());
    std::printf("soak: %d runs in %.2f min (%d not done)\n", runs, samples.back().t_min, not_done);
    std::printf("soak: RSS first %ld kB, last %ld kB, min %ld kB, peak %ld kB; trend over the second half %+.1f kB/min\n",
                samples.front().rss_kb, samples.back().rss_kb, rss_min->rss_kb, rss_max->rss_kb,
                rss_slope_kb_per_min(second_half));
    std::printf("soak: open fds first %ld, last %ld, peak %ld\n", samples.front().fds, samples.back().fds, fds_max->fds);
    if (not_done > 0) rc = 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "standcal-bench-soak: %s\n", e.what());
    rc = 1;
  }
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return rc;
}
