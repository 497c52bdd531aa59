"""A display for ParaView's scripts on a machine without one: `ensure_display()` re-runs the
calling script on its own Xvfb when DISPLAY is unset, and stops the server after.

Xvfb's `-displayfd` names the display only once the server accepts clients, so no client
connects too early, and `-noreset` keeps the server from resetting when its last client
disconnects: ParaView closes its first connection (the rendering-capability probe) and opens
another, and one that lands in the reset fails with "bad X server connection" (xvfb-run,
which resets, aborted 5 of 6 runs on a loaded host). Under xvfb-run, or at a desktop,
DISPLAY is set and nothing happens.
"""
import os
import subprocess
import sys


def ensure_display():
    if os.environ.get("DISPLAY"):
        return
    read, write = os.pipe()
    try:
        server = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1280x1024x24", "-nolisten", "tcp", "-noreset"],
                                  pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except FileNotFoundError:
        sys.exit("no display and no Xvfb: install Debian's xvfb (or run under xvfb-run)")
    os.close(write)
    number = b""
    while not number.endswith(b"\n"):
        chunk = os.read(read, 16)
        if not chunk:
            sys.exit(f"Xvfb ended before it named its display (exit {server.wait()})")
        number += chunk
    os.close(read)
    try:
        code = subprocess.call([sys.executable, *sys.argv], env={**os.environ, "DISPLAY": ":" + number.decode().strip()})
    finally:
        server.terminate()
        server.wait()
    sys.exit(code)
