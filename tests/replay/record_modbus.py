#!/usr/bin/env python3
"""Records the Modbus TCP exchanges of `standcal stand` commands (tests/replay/modbus/).

  tests/replay/record_modbus.py BUILD_DIR OUT.mbtrace -- COMMAND [; COMMAND ...]

Starts standcal-stand-emu on loopback and a recording proxy in front of it, then runs
each `standcal stand --url tcp://PROXY?unit=1 COMMAND` in turn (commands separated by
';', e.g. `status ; enable ; home ; move 90 -45 ; estop ; status ; reset`). The proxy
relays every request and reply unchanged and writes them, per connection:

  @ COMMAND                the `standcal stand` arguments of the connection that follows
  @@ ...                   a further connection of the same command (a re-open)
  > UU FF DD DD ...        a request: unit id, function code, data (the MBAP header left
  < UU FF DD DD ...        out) and the controller's reply, in hex

after a provenance header of '#' lines. Against a real controller instead of the emulator,
set STANDCAL_RECORD_UPSTREAM=HOST:PORT (its Modbus TCP address; unit 1) and edit the header.
"""
import os
import socket
import struct
import subprocess
import sys
import threading
import time


def relay(client: socket.socket, upstream: socket.socket, log: list) -> None:
    """Relays one connection's ADUs, logging unit id + PDU of each request and reply."""

    def read_adu(s: socket.socket):
        header = b""
        while len(header) < 7:
            chunk = s.recv(7 - len(header))
            if not chunk:
                return None
            header += chunk
        length = struct.unpack(">H", header[4:6])[0]
        body = b""
        while len(body) < length - 1:
            chunk = s.recv(length - 1 - len(body))
            if not chunk:
                return None
            body += chunk
        return header, body

    try:
        while True:
            request = read_adu(client)
            if request is None:
                break
            upstream.sendall(request[0] + request[1])
            reply = read_adu(upstream)
            if reply is None:
                break
            log.append("> " + (request[0][6:7] + request[1]).hex(" ").upper())
            log.append("< " + (reply[0][6:7] + reply[1]).hex(" ").upper())
            client.sendall(reply[0] + reply[1])
    except OSError:  # the command exited before its last reply arrived
        pass
    finally:  # the emulator serves one connection at a time: free it for the next command
        client.close()
        upstream.close()


def main() -> int:
    if len(sys.argv) < 4 or "--" not in sys.argv:
        print(__doc__, file=sys.stderr)
        return 2
    build, out = sys.argv[1], sys.argv[2]
    commands = [c.split() for c in " ".join(sys.argv[sys.argv.index("--") + 1:]).split(";")]
    upstream = os.environ.get("STANDCAL_RECORD_UPSTREAM")
    emu = None
    if upstream:
        host, port = upstream.rsplit(":", 1)
    else:
        emu = subprocess.Popen([f"{build}/tools/stand-emu/standcal-stand-emu", "--listen",
                                "tcp://127.0.0.1:0", "--time-scale", "10", "--noise-deg", "0"],
                               stdout=subprocess.PIPE, text=True)
        emulator_url = emu.stdout.readline().strip()  # tcp://127.0.0.1:PORT
        host, port = emulator_url[len("tcp://"):].split(":")
    proxy = socket.socket()
    proxy.bind(("127.0.0.1", 0))
    proxy.listen(4)
    proxy_url = f"tcp://127.0.0.1:{proxy.getsockname()[1]}?unit=1"
    upstream_port = int(port.split("?")[0])
    # A command may open more than one connection (a re-open after an emergency stop's
    # reset): every connection accepted while it runs is logged under it, in order.
    current: list = []  # the running command's connections, each a list of lines
    relays = []

    def accept_forever():
        while True:
            try:
                client, _ = proxy.accept()
            except OSError:
                return
            upstream = socket.create_connection((host, upstream_port))
            log: list = []
            current.append(log)
            t = threading.Thread(target=relay, args=(client, upstream, log))
            t.start()
            relays.append(t)

    threading.Thread(target=accept_forever, daemon=True).start()
    lines = []
    status = 0
    for command in commands:
        current = []
        result = subprocess.run([f"{build}/tools/standcal/standcal", "stand", "--url", proxy_url,
                                 *command], capture_output=True, text=True)
        for t in relays:
            t.join(timeout=10)
        status |= result.returncode
        print(f"$ standcal stand {' '.join(command)}: exit {result.returncode}\n"
              f"{result.stdout}{result.stderr}", file=sys.stderr)
        lines.append("@ " + " ".join(command))
        for n, log in enumerate(current):
            if n > 0:
                lines.append("@@ another connection of the same command")
            lines.extend(log)
    proxy.close()
    if emu:
        emu.terminate()
        emu.wait()
    with open(out, "w") as f:
        f.write("# Recorded by tests/replay/record_modbus.py from standcal-stand-emu\n")
        # No encoder noise: a replayed in-position wait may end a poll earlier or later than
        # the recorded one, and must then print the same settled angle.
        f.write("# (--time-scale 10 --noise-deg 0, the default register map) with:\n")
        f.write("#   tests/replay/record_modbus.py BUILD_DIR OUT -- "
                + " ; ".join(" ".join(c) for c in commands) + "\n")
        connections = sum(1 for l in lines if l.startswith("@"))
        f.write(f"# {sum(1 for l in lines if l.startswith('>'))} exchanges in {connections} "
                f"connections of {len(commands)} commands, "
                f"{time.strftime('%Y-%m-%d', time.gmtime())}.\n")
        f.write("\n".join(lines) + "\n")
    return status


if __name__ == "__main__":
    sys.exit(main())
