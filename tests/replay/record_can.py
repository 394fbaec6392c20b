#!/usr/bin/env python3
"""Records the CAN frames standcal-can-emu sends as a candump -L log (tests/replay/can/).

  tests/replay/record_can.py BUILD_DIR OUT.candump -- [standcal-can-emu options...]

The emulator writes real `struct can_frame` bytes to one end of a
socketpair(AF_UNIX, SOCK_SEQPACKET) (this machine's kernel has no CAN); this script reads
the other end and writes one candump line per frame, "(seconds) fd0 ID#DATA", after a
provenance header of '#' lines naming the command. Where a machine has a CAN interface,
`candump -L can0 > FILE` records a real unit in the same format (add the header by hand).
"""
import socket
import subprocess
import struct
import sys
import time

CAN_EFF_FLAG = 0x80000000
CAN_ERR_FLAG = 0x20000000


def main() -> int:
    if len(sys.argv) < 3 or "--" not in sys.argv:
        print(__doc__, file=sys.stderr)
        return 2
    build, out = sys.argv[1], sys.argv[2]
    emu_args = sys.argv[sys.argv.index("--") + 1:]
    emu = f"{build}/tools/can-emu/standcal-can-emu"
    ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    proc = subprocess.Popen([emu, "--fd", str(theirs.fileno()), *emu_args],
                            pass_fds=[theirs.fileno()])
    theirs.close()
    start = time.monotonic()
    lines = []
    while True:
        frame = ours.recv(72)
        if not frame:
            break
        can_id, length = struct.unpack_from("<IB", frame)
        data = frame[8:8 + length].hex().upper()
        ident = (f"{can_id & 0x1FFFFFFF:08X}" if can_id & CAN_EFF_FLAG
                 else f"{can_id & 0x7FF:03X}")
        if can_id & CAN_ERR_FLAG:
            ident = f"{can_id & 0x1FFFFFFF | CAN_ERR_FLAG:08X}"
        lines.append(f"({time.monotonic() - start:.6f}) fd0 {ident}#{data}")
    proc.wait()
    with open(out, "w") as f:
        f.write("# Recorded by tests/replay/record_can.py from standcal-can-emu:\n")
        f.write("#   standcal-can-emu --fd N " + " ".join(emu_args) + "\n")
        f.write(f"# {len(lines)} frames, {time.strftime('%Y-%m-%d', time.gmtime())}.\n")
        f.write("\n".join(lines) + "\n")
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main())
