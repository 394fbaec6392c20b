// standcal-bench-soak [--minutes M] [--time-scale K] [--dwell-s D] [--warmup-s W] [--sample-s S]
//                     [--max-rss-kb-per-run R] [--max-fds-per-run F] [--daemon PATH]
//                     [--daemon-wrapper CMD] [--trim-at-end] [--no-runs-list]
// Starts a real standcald on the simulated backend in a temporary directory and runs
// paper9 back to back for M minutes (default 30). Each run is followed by a fresh
// subscriber connection, a few requesters and the run's result, so every connection
// path opens and closes. Every S seconds it prints the daemon's RSS (/proc/PID/status)
// and open fd count (/proc/PID/fd); at the end the first, last and peak values and the
// least-squares slope of RSS (kB/run) and fds (fds/run) over the second half of the
// samples, the first half being warm-up (caches, arenas, the first runs' allocations).
// The verdict is "flat" when both slopes are at most the thresholds; exit status 2 when
// not. --daemon-wrapper runs the daemon under a tool (e.g. "valgrind --tool=massif") for
// heap profiling; its RSS is then the tool's too. --trim-at-end asks glibc, through gdb,
// to return free heap pages (malloc_trim(0)) after the last sample and prints the RSS
// before and after: what is only freed-but-kept memory drops, live memory stays.
// --daemon runs a copy of standcald (so rebuilding the tree meanwhile leaves the soak
// and gdb's view of the binary alone).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
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
  long anon_kb = 0;  // RssAnon: heap, arenas, stacks — what a leak grows
  long file_kb = 0;  // RssFile: pages of the binary, libraries and mapped files
  long fds = 0;
};

// A "Name:   123 kB" line of /proc/PID/status; -1 when missing.
long status_kb(pid_t pid, const std::string& name) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(name + ":", 0) == 0) return std::stol(line.substr(name.size() + 1));
  }
  return -1;
}

long rss_kb_of(pid_t pid) { return status_kb(pid, "VmRSS"); }

long open_fds_of(pid_t pid) {
  std::error_code ec;
  long n = 0;
  for (auto it = std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec);
       !ec && it != std::filesystem::directory_iterator(); it.increment(ec)) {
    ++n;
  }
  return ec ? -1 : n;
}

// Least-squares slope of y over x across the samples given (0 when x does not vary).
template <typename X, typename Y>
double slope(const std::vector<Sample>& s, X x_of, Y y_of) {
  if (s.size() < 2) return 0;
  double mx = 0, my = 0;
  for (const auto& v : s) mx += x_of(v), my += y_of(v);
  mx /= static_cast<double>(s.size());
  my /= static_cast<double>(s.size());
  double num = 0, den = 0;
  for (const auto& v : s) {
    num += (x_of(v) - mx) * (y_of(v) - my);
    den += (x_of(v) - mx) * (x_of(v) - mx);
  }
  return den > 0 ? num / den : 0;
}

double runs_of(const Sample& s) { return s.runs; }
double rss_of(const Sample& s) { return static_cast<double>(s.rss_kb); }
double anon_of(const Sample& s) { return static_cast<double>(s.anon_kb); }
double file_of(const Sample& s) { return static_cast<double>(s.file_kb); }
double fds_of(const Sample& s) { return static_cast<double>(s.fds); }

pid_t start_daemon(const std::string& dir, double time_scale, const std::string& daemon,
                   const std::string& wrapper) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const std::string log = dir + "/standcald.log";
    if (std::freopen(log.c_str(), "w", stderr) == nullptr) ::_exit(126);
    const std::string ts = std::to_string(time_scale);
    const std::string socket = dir + "/standcald.sock";
    const std::string state = dir + "/state";
    if (!wrapper.empty()) {
      // The shell execs the tool in this process, so the pid sampled is the tool's.
      const std::string cmd = "exec " + wrapper + " '" + daemon + "' --sim --socket '" + socket +
                              "' --state-dir '" + state + "' --time-scale " + ts +
                              " --log-level warn";
      ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::execl(daemon.c_str(), daemon.c_str(), "--sim", "--socket", socket.c_str(), "--state-dir",
            state.c_str(), "--time-scale", ts.c_str(), "--log-level", "warn",
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  return pid;
}

// One run with a subscriber following it and requesters asking meanwhile; closes them all.
std::string one_run(const std::string& socket, int index, double dwell_s, double warmup_s,
                    bool list_runs) {
  Client control(socket);
  Client subscriber(socket);
  subscriber.call("subscribe", {{"events", "all"}});
  const std::string run_id =
      control.call("run.start", {{"program", "paper9"},
                                 {"unit_serial", "SOAK-" + std::to_string(index % 5)},
                                 {"dwell_s", dwell_s},
                                 {"warmup_s", warmup_s},
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
  if (list_runs) control.call("runs.list");
  return state;
}

// "1.52 1.31 0.90" (1, 5, 15 min): the soak shares the machine, the figures say how much.
std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

// Free heap pages glibc keeps (freed chunks, arena tops) count in RSS until trimmed.
// The gap between RSS before and after malloc_trim(0) is memory the allocator holds,
// not memory the daemon holds.
// malloc_stats() goes to the daemon's stderr (its log): its totals say how much the
// arenas hold from the system against how much is in use, before and after the trim.
void trim_and_report(pid_t pid, const std::string& daemon_log) {
  const long before_kb = rss_kb_of(pid), before_anon_kb = status_kb(pid, "RssAnon");
  const std::string cmd = "gdb -p " + std::to_string(pid) +
                          " -batch -ex 'call (void)malloc_stats()' -ex 'call (int)malloc_trim(0)'"
                          " -ex 'call (void)malloc_stats()' >/dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  std::this_thread::sleep_for(200ms);
  const long after_kb = rss_kb_of(pid), after_anon_kb = status_kb(pid, "RssAnon");
  std::printf(
      "soak: malloc_trim(0) through gdb (exit %d): RSS %ld kB -> %ld kB (%+ld kB), anon %ld kB -> "
      "%ld kB\n",
      status, before_kb, after_kb, after_kb - before_kb, before_anon_kb, after_anon_kb);
  std::ifstream log(daemon_log);
  int totals = 0, lines_left = 0;  // the two lines after each "Total (incl. mmap):"
  for (std::string line; std::getline(log, line);) {
    if (line.rfind("Total (incl. mmap):", 0) == 0) {
      ++totals;
      lines_left = 2;
    } else if (lines_left > 0) {
      --lines_left;
      std::printf("soak: malloc_stats, all arenas, %s trim: %s\n", totals == 1 ? "before" : "after",
                  line.c_str());
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "standcal-bench-soak: back-to-back simulated runs, printing the daemon's RSS and open fds"};
  double minutes = 30, time_scale = 200, dwell_s = 10, warmup_s = 0, sample_s = 10;
  app.add_option("--minutes", minutes, "how long to run (default 30)")
      ->check(CLI::Range(0.1, 24 * 60.0));
  app.add_option("--time-scale", time_scale,
                 "simulated time runs this many times faster (default 200)")
      ->check(CLI::Range(1.0, 10000.0));
  app.add_option("--dwell-s", dwell_s, "dwell per position, simulated seconds (default 10)")
      ->check(CLI::Range(0.5, 600.0));
  // A warm-up of hours is written to the recording as it is taken: the peak RSS shows whether
  // the daemon holds it (four runs' 7200 s at 100 Hz had peaked at 184 MB when it did).
  app.add_option("--warmup-s", warmup_s,
                 "each run's warm-up at position 1, simulated seconds (default 0: none)")
      ->check(CLI::Range(0.0, 36000.0));
  app.add_option("--sample-s", sample_s, "seconds between samples (default 10)")
      ->check(CLI::Range(0.5, 600.0));
  // 1 kB/run is 1 MB per thousand runs, about a year of a busy bench; the per-run state
  // the daemon must keep (a run's index entry) is far below it.
  double max_rss_kb_per_run = 1.0, max_fds_per_run = 0.01;
  app.add_option("--max-rss-kb-per-run", max_rss_kb_per_run,
                 "RSS slope still called flat (default 1.0 kB/run)");
  app.add_option("--max-fds-per-run", max_fds_per_run,
                 "fd slope still called flat (default 0.01 fd/run)");
  std::string daemon = STANDCALD_PATH, wrapper;
  bool trim_at_end = false, no_runs_list = false;
  // runs.list answers with one page (100 runs by default); without it the soak shows what
  // the rest costs per run.
  app.add_flag("--no-runs-list", no_runs_list, "do not call runs.list after each run");
  app.add_option("--daemon", daemon, "the standcald binary (default: this build's)");
  app.add_flag("--trim-at-end", trim_at_end,
               "call malloc_trim(0) in the daemon through gdb at the end, print RSS");
  app.add_option("--daemon-wrapper", wrapper,
                 "run standcald under this command, e.g. \"heaptrack -o /tmp/soak\"");
  CLI11_PARSE(app, argc, argv);

  std::string dir = (std::filesystem::temp_directory_path() / "standcal-soak-XXXXXX").string();
  if (::mkdtemp(dir.data()) == nullptr) return 1;
  const std::string socket = dir + "/standcald.sock";
  const pid_t pid = start_daemon(dir, time_scale, daemon, wrapper);
  int rc = 0;
  std::vector<Sample> samples;
  try {
    for (int i = 0;; ++i) {
      try {
        Client probe(socket);
        break;
      } catch (const std::exception&) {
        if (i > 3000) throw;  // a profiler-wrapped daemon starts slowly
        std::this_thread::sleep_for(20ms);
      }
    }
    std::printf(
        "soak: standcald pid %d, paper9 dwell %.1f s (warm-up %.0f s) at time x%.0f, %.1f min, "
        "sample every %.1f s; load average %s\n",
        pid, dwell_s, warmup_s, time_scale, minutes, sample_s, load_average().c_str());
    std::printf("%8s %6s %10s %10s %10s %6s\n", "t_min", "runs", "rss_kb", "anon_kb", "file_kb",
                "fds");
    const auto t0 = Clock::now();
    const auto end = t0 + std::chrono::duration_cast<Clock::duration>(
                              std::chrono::duration<double, std::ratio<60>>(minutes));
    const auto sample_period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(sample_s));
    auto next_sample = t0;
    int runs = 0, not_done = 0;
    auto sample = [&] {
      Sample s{std::chrono::duration<double, std::ratio<60>>(Clock::now() - t0).count(),
               runs,
               rss_kb_of(pid),
               status_kb(pid, "RssAnon"),
               status_kb(pid, "RssFile"),
               open_fds_of(pid)};
      samples.push_back(s);
      std::printf("%8.2f %6d %10ld %10ld %10ld %6ld\n", s.t_min, s.runs, s.rss_kb, s.anon_kb,
                  s.file_kb, s.fds);
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
        const std::string state = one_run(socket, runs, dwell_s, warmup_s, !no_runs_list);
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
    const auto [rss_min, rss_max] =
        std::minmax_element(samples.begin(), samples.end(),
                            [](const Sample& a, const Sample& b) { return a.rss_kb < b.rss_kb; });
    const auto fds_max =
        std::max_element(samples.begin(), samples.end(),
                         [](const Sample& a, const Sample& b) { return a.fds < b.fds; });
    const std::vector<Sample> second_half(samples.begin() + static_cast<long>(samples.size() / 2),
                                          samples.end());
    const double rss_kb_per_run = slope(second_half, runs_of, rss_of);
    const double fds_per_run = slope(second_half, runs_of, fds_of);
    const bool rss_flat = rss_kb_per_run <= max_rss_kb_per_run;
    const bool fds_flat = fds_per_run <= max_fds_per_run;
    std::printf("soak: %d runs in %.2f min (%d not done); load average at the end %s\n", runs,
                samples.back().t_min, not_done, load_average().c_str());
    std::printf("soak: RSS first %ld kB, last %ld kB, min %ld kB, peak %ld kB\n",
                samples.front().rss_kb, samples.back().rss_kb, rss_min->rss_kb, rss_max->rss_kb);
    // The kernel's high-water mark: a peak between two samples (a fit, a long dwell) too.
    std::printf("soak: VmHWM (the daemon's peak RSS since it started) %ld kB\n",
                status_kb(pid, "VmHWM"));
    std::printf("soak: open fds first %ld, last %ld, peak %ld\n", samples.front().fds,
                samples.back().fds, fds_max->fds);
    std::printf(
        "soak: second half (runs %d to %d, %zu samples): RSS %+.3f kB/run (anon %+.3f, file "
        "%+.3f), "
        "fds %+.4f fds/run\n",
        second_half.front().runs, second_half.back().runs, second_half.size(), rss_kb_per_run,
        slope(second_half, runs_of, anon_of), slope(second_half, runs_of, file_of), fds_per_run);
    std::printf(
        "soak: verdict: RSS %s (%+.3f kB/run, threshold %.3f), fds %s (%+.4f fds/run, threshold "
        "%.4f)\n",
        rss_flat ? "FLAT" : "NOT FLAT", rss_kb_per_run, max_rss_kb_per_run,
        fds_flat ? "FLAT" : "NOT FLAT", fds_per_run, max_fds_per_run);
    if (trim_at_end) trim_and_report(pid, dir + "/standcald.log");
    if (not_done > 0) rc = 1;
    if (rc == 0 && !(rss_flat && fds_flat)) rc = 2;
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
