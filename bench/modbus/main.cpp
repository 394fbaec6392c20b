// Modbus request round-trips per second against standcal-stand-emu on loopback TCP:
//   raw_read_status   one libmodbus read of an axis status block (6 registers)
//   raw_write_command one libmodbus write of a target+speed+command block (4 registers)
//   stand_read_state  ModbusStand::read_state: the same read through the driver's I/O
//                     thread (queue hand-off, decoding), with its heartbeat running
// Usage: standcal-bench-modbus [--emulator PATH] [google-benchmark flags]
#include <benchmark/benchmark.h>
#include <modbus.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "drivers/modbus/modbus_stand.hpp"

extern char** environ;

namespace {

namespace mb = standcal::drivers::modbus;

std::string g_url;  // where the emulator listens

// Starts the emulator on a free port and returns its pid; g_url is set from its first line.
pid_t start_emulator(const std::string& path) {
  int out[2];
  if (pipe(out) != 0) return -1;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, out[0]);
  std::vector<std::string> args{path, "--listen", "tcp://127.0.0.1:0"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, path.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(out[1]);
  if (rc != 0) return -1;
  pollfd readable{out[0], POLLIN, 0};
  char c = 0;
  while (poll(&readable, 1, 10000) > 0 && read(out[0], &c, 1) == 1 && c != '\n') g_url += c;
  close(out[0]);
  return pid;
}

modbus_t* connect_raw() {
  auto url = mb::parse_url(g_url);
  modbus_t* ctx =
      modbus_new_tcp_pi(url.value().host.c_str(), std::to_string(url.value().port).c_str());
  if (ctx == nullptr || modbus_connect(ctx) == -1) return nullptr;
  return ctx;
}

void raw_read_status(benchmark::State& state) {
  modbus_t* ctx = connect_raw();
  if (ctx == nullptr) return state.SkipWithError("cannot connect to the emulator");
  std::uint16_t regs[6];
  for (auto _ : state) {
    if (modbus_read_input_registers(ctx, 100, 6, regs) != 6)
      return state.SkipWithError(modbus_strerror(errno));
    benchmark::DoNotOptimize(regs);
  }
  state.SetItemsProcessed(state.iterations());
  modbus_close(ctx);
  modbus_free(ctx);
}

void raw_write_command(benchmark::State& state) {
  modbus_t* ctx = connect_raw();
  if (ctx == nullptr) return state.SkipWithError("cannot connect to the emulator");
  const std::uint16_t block[4] = {0, 0, 0, 0};  // target 0, speed default, no command
  for (auto _ : state) {
    if (modbus_write_registers(ctx, 100, 4, block) != 4)
      return state.SkipWithError(modbus_strerror(errno));
  }
  state.SetItemsProcessed(state.iterations());
  modbus_close(ctx);
  modbus_free(ctx);
}

void stand_read_state(benchmark::State& state) {
  auto stand = mb::ModbusStand::create(g_url, mb::ModbusStandConfig{});
  if (!stand || !stand.value()->configure())
    return state.SkipWithError("cannot configure the stand");
  for (auto _ : state) {
    auto s = stand.value()->read_state(standcal::drivers::StandAxis::outer);
    if (!s) return state.SkipWithError(s.status().message.c_str());
    benchmark::DoNotOptimize(s.value().angle_deg);
  }
  state.SetItemsProcessed(state.iterations());
}

BENCHMARK(raw_read_status)->UseRealTime()->MinTime(1.0);
BENCHMARK(raw_write_command)->UseRealTime()->MinTime(1.0);
BENCHMARK(stand_read_state)->UseRealTime()->MinTime(1.0);

}  // namespace

int main(int argc, char** argv) {
  std::string emulator = STANDCAL_STAND_EMU_PATH;
  if (argc >= 3 && std::strcmp(argv[1], "--emulator") == 0) {
    emulator = argv[2];
    argv[2] = argv[0];
    argc -= 2;
    argv += 2;
  }
  const pid_t pid = start_emulator(emulator);
  if (pid <= 0 || g_url.empty()) {
    std::fprintf(stderr, "standcal-bench-modbus: cannot start %s\n", emulator.c_str());
    return 1;
  }
  std::printf("emulator at %s (items_per_second = Modbus request round-trips per second)\n",
              g_url.c_str());
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  kill(pid, SIGTERM);
  waitpid(pid, nullptr, 0);
  return 0;
}
