#include "daemon/standcald/diagnose_worker.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <iterator>

#include "calib/json_text.hpp"
#include "daemon/standcald/diagnose_job.hpp"
#include "daemon/standcald/errno_text.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"

extern char** environ;

namespace standcal::daemon {

using nlohmann::json;
using protocol::ErrorCode;
using protocol::RpcError;

namespace {

// A sanitizer reserves terabytes of shadow address space: under ASan or TSan the child's
// address-space limit would fail its start-up (TSan: "Failed to mmap", exit status 66).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

// A diagnosis needs well under 1 GiB; past this the child fails its allocation instead of
// pushing the stand's process out of memory.
constexpr rlim_t kWorkerAddressSpace_bytes = rlim_t{8} << 30;

json axis_range_to_json(const AxisRange& r) {
  return {{"continuous", r.continuous},
          {"min_deg", r.min_deg},
          {"max_deg", r.max_deg},
          {"cable_wrap", r.cable_wrap == CableWrap::centred ? "centred" : "nearest"}};
}

AxisRange axis_range_from_json(const json& j) {
  return {
      j.at("continuous").get<bool>(), j.at("min_deg").get<double>(), j.at("max_deg").get<double>(),
      j.at("cable_wrap").get<std::string>() == "centred" ? CableWrap::centred : CableWrap::nearest};
}

json job_to_json(const DiagnoseJob& job) {
  return {{"run_status", job.run_status},
          {"limits",
           {{"alpha1", axis_range_to_json(job.limits.alpha1)},
            {"alpha2", axis_range_to_json(job.limits.alpha2)}}},
          {"report", job.with_report},
          {"unit_wander_ug", job.unit_wander.size_ug},
          {"unit_wander_axes_ug",
           {job.unit_wander.size_axes_ug[0], job.unit_wander.size_axes_ug[1],
            job.unit_wander.size_axes_ug[2]}},
          {"unit_wander_tau_s", job.unit_wander.tau_s},
          {"unit_known_tau_s",
           job.unit_wander.known_tau
               ? json::array({job.unit_wander.known_tau->min_s, job.unit_wander.known_tau->max_s})
               : json(nullptr)}};
}

DiagnoseJob job_from_json(const json& j) {
  DiagnoseJob job;
  job.run_status = j.at("run_status");
  job.limits.alpha1 = axis_range_from_json(j.at("limits").at("alpha1"));
  job.limits.alpha2 = axis_range_from_json(j.at("limits").at("alpha2"));
  job.with_report = j.at("report").get<bool>();
  job.unit_wander.size_ug = j.at("unit_wander_ug").get<double>();
  const json& axes = j.at("unit_wander_axes_ug");
  job.unit_wander.size_axes_ug =
      Vec3(axes.at(0).get<double>(), axes.at(1).get<double>(), axes.at(2).get<double>());
  job.unit_wander.tau_s = j.at("unit_wander_tau_s").get<double>();
  if (const json& tau = j.at("unit_known_tau_s"); !tau.is_null())
    job.unit_wander.known_tau = KnownTau{tau.at(0).get<double>(), tau.at(1).get<double>()};
  return job;
}

std::string run_id_of(const DiagnoseJob& job) { return job.run_status.value("run_id", ""); }

// Pipes whose ends the daemon keeps are close-on-exec: no other child inherits them.
void make_pipe(int fds[2]) {
  if (::pipe2(fds, O_CLOEXEC) != 0)
    throw RpcError(ErrorCode::internal_error, "run.diagnose: pipe: " + errno_text());
}

// Starts `exe --diagnose-worker` with stdin/stdout on the pipes, stderr shared (the
// journal), default signal dispositions and an empty mask (the daemon blocks SIGTERM for
// its signalfd), and no other descriptor of the daemon's.
pid_t spawn_worker(const std::string& exe, int stdin_fd, int stdout_fd) {
  posix_spawn_file_actions_t files;
  posix_spawn_file_actions_init(&files);
  posix_spawn_file_actions_adddup2(&files, stdin_fd, 0);
  posix_spawn_file_actions_adddup2(&files, stdout_fd, 1);
  posix_spawn_file_actions_addclosefrom_np(&files, 3);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none, all;
  sigemptyset(&none);
  sigfillset(&all);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &all);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  std::string flag = kDiagnoseWorkerFlag;
  std::string program = exe;
  char* argv[] = {program.data(), flag.data(), nullptr};
  pid_t pid = 0;
  const int rc = ::posix_spawn(&pid, exe.c_str(), &files, &attr, argv, environ);
  posix_spawn_file_actions_destroy(&files);
  posix_spawnattr_destroy(&attr);
  if (rc != 0)
    throw RpcError(ErrorCode::internal_error, "run.diagnose: cannot start the diagnosis process " +
                                                  exe + ": " + std::strerror(rc));
  return pid;
}

void write_all(int fd, const std::string& text) {
  for (std::size_t done = 0; done < text.size();) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;  // the child is gone: its exit status tells why
    done += static_cast<std::size_t>(n);
  }
}

// Reads the child's whole answer; false when `timeout_s` passed first.
bool read_all(int fd, double timeout_s, std::string& out) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  char buf[65536];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
    if (ready < 0 && errno != EINTR) return true;
    if (ready <= 0) continue;
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return true;
    out.append(buf, static_cast<std::size_t>(n));
  }
}

int wait_child(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

// The answer the child gave, or the error that says what became of it.
json answer_of(const DiagnoseJob& job, int status, bool timed_out, const std::string& out) {
  const std::string who = "run " + run_id_of(job) + ": ";
  const std::string offline =
      "; the daemon, the stand and the run are unaffected (reproduce offline: standcal diagnose " +
      job.run_status.value("recording_path", std::string("RECORDING")) + ")";
  if (timed_out)
    throw RpcError(ErrorCode::internal_error,
                   who + "the diagnosis took longer than " +
                       std::to_string(static_cast<int>(kDiagnoseWorkerTimeout_s)) +
                       " s and was stopped" + offline);
  if (WIFSIGNALED(status))
    throw RpcError(ErrorCode::internal_error, who + "the diagnosis process died of signal " +
                                                  std::to_string(WTERMSIG(status)) + " (" +
                                                  ::strsignal(WTERMSIG(status)) + ")" + offline);
  const json answer = json::parse(out, nullptr, false);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !answer.is_object())
    throw RpcError(ErrorCode::internal_error,
                   who + "the diagnosis process ended with status " +
                       std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
                       " and no readable answer" + offline);
  if (answer.contains("error"))
    throw RpcError(answer["error"].value("code", static_cast<int>(ErrorCode::internal_error)),
                   answer["error"].value("message", who + "the diagnosis failed"));
  return answer.at("result");
}

// The child's limits: it must never starve or outgrow the process that drives the stand.
void limit_worker() {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::nice(10) == -1 && errno != 0) spdlog::debug("diagnosis worker: nice: {}", errno_text());
  const auto cpu_s = static_cast<rlim_t>(kDiagnoseWorkerTimeout_s) + 10;
  const rlimit cpu{cpu_s, cpu_s + 5};
  ::setrlimit(RLIMIT_CPU, &cpu);
  if (!kSanitized) {
    const rlimit as{kWorkerAddressSpace_bytes, kWorkerAddressSpace_bytes};
    ::setrlimit(RLIMIT_AS, &as);
  }
}

json error_answer(int code, const std::string& message) {
  return {{"error", {{"code", code}, {"message", message}}}};
}

}  // namespace

json diagnose_in_child(const DiagnoseJob& job, const std::string& exe, double timeout_s,
                       std::atomic<pid_t>& child_pid) {
  // Made before any pipe or child exists: nothing after the spawn may throw and leave the
  // worker waiting on its stdin.
  const std::string job_text = json_text(job_to_json(job), -1);
  int to_child[2], from_child[2];
  make_pipe(to_child);
  make_pipe(from_child);
  pid_t pid = 0;
  try {
    pid = spawn_worker(exe, to_child[0], from_child[1]);
  } catch (...) {
    for (int fd : {to_child[0], to_child[1], from_child[0], from_child[1]}) ::close(fd);
    throw;
  }
  child_pid = pid;
  ::close(to_child[0]);
  ::close(from_child[1]);
  write_all(to_child[1], job_text);
  ::close(to_child[1]);
  std::string out;
  const bool finished = read_all(from_child[0], timeout_s, out);
  ::close(from_child[0]);
  if (!finished) ::kill(pid, SIGKILL);
  const int status = wait_child(pid);
  child_pid = 0;
  return answer_of(job, status, !finished, out);
}

int diagnose_worker_main() {
  spdlog::set_default_logger(spdlog::stderr_color_mt("standcald-diagnose"));
  spdlog::set_pattern("%Y-%m-%d %H:%M:%S.%e [%l] diagnosis: %v");
  limit_worker();
  json answer;
  try {
    const std::string input{std::istreambuf_iterator<char>(std::cin),
                            std::istreambuf_iterator<char>()};
    const DiagnoseJob job = job_from_json(json::parse(input));
    const char* fault = std::getenv(kDiagnoseWorkerFaultEnv);
    if (fault != nullptr && std::string(fault) == "abort") std::abort();
    answer = {
        {"result", diagnose_run(job.run_status, job.limits, job.unit_wander, job.with_report)}};
  } catch (const RpcError& e) {
    answer = error_answer(e.code(), e.what());
  } catch (const std::exception& e) {
    answer = error_answer(static_cast<int>(ErrorCode::internal_error),
                          std::string("diagnosis failed: ") + e.what());
  }
  // A recording path or message with bytes that are not UTF-8 must not lose the answer.
  std::cout << answer.dump(-1, ' ', false, json::error_handler_t::replace) << std::flush;
  return std::cout.good() ? 0 : 1;
}

}  // namespace standcal::daemon
