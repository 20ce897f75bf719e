#!/usr/bin/env python3
"""Memory of `bw4t serve --http` under WebSockets that each hold an unfinished message.

Starts BINARY as `serve --port 0 --http 0`, reads its resident memory (VmRSS in
/proc/PID/status), opens N WebSockets on /ws that never say `hello`, and on each sends
the first SIZE bytes of a text message in 1 MiB fragments (a first frame and
continuation frames, none final), then holds the connection. When the server's memory
has settled it prints one JSON line: memory before and after, per connection, and how
many connections the server closed. Only the standard library is used.

    cargo build --release
    python3 tests/tools/ws_memory.py target/release/bw4t --connections 6 --message-bytes 47185920
    python3 tests/tools/ws_memory.py target/release/bw4t --connections 200 --message-bytes 65535

This is a measuring tool, not a test: it waits on the wall clock for memory to settle.
"""

import argparse
import base64
import json
import os
import socket
import subprocess
import sys
import time

CHUNK = 1 << 20


def rss_kb(pid):
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def settled_rss_kb(pid, quiet=2.0, limit=120.0):
    """VmRSS once it has not changed for `quiet` seconds (or after `limit` seconds)."""
    start = time.monotonic()
    last, since = rss_kb(pid), time.monotonic()
    while time.monotonic() - start < limit:
        time.sleep(0.25)
        now = rss_kb(pid)
        if now != last:
            last, since = now, time.monotonic()
        elif time.monotonic() - since >= quiet:
            break
    return last


def client_frame(opcode, fin, payload):
    """A masked client frame; the mask is zeros, so the payload goes as it is."""
    head = bytes([(0x80 if fin else 0) | opcode])
    n = len(payload)
    if n < 126:
        head += bytes([0x80 | n])
    elif n < 1 << 16:
        head += bytes([0x80 | 126]) + n.to_bytes(2, "big")
    else:
        head += bytes([0x80 | 127]) + n.to_bytes(8, "big")
    return head + b"\0\0\0\0" + payload


def open_websocket(host, port):
    sock = socket.create_connection((host, port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        f"GET /ws HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
        f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n".encode()
    )
    head = b""
    while b"\r\n\r\n" not in head:
        data = sock.recv(4096)
        if not data:
            raise RuntimeError("the server closed the handshake")
        head += data
    if not head.startswith(b"HTTP/1.1 101"):
        raise RuntimeError(head.split(b"\r\n")[0].decode())
    return sock


def send_unfinished(sock, size):
    """Sends `size` bytes of a text message, never its last frame. False if refused."""
    sent, opcode = 0, 0x1
    try:
        while sent < size:
            part = min(CHUNK, size - sent)
            sock.sendall(client_frame(opcode, False, b"x" * part))
            sent, opcode = sent + part, 0x0
    except OSError:
        return False
    return True


def closed_by_server(sock):
    sock.setblocking(False)
    try:
        while sock.recv(65536):
            pass
        return True  # end of stream after the server's last words
    except BlockingIOError:
        return False  # nothing to read: still open
    except OSError:
        return True  # reset


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("binary")
    parser.add_argument("--connections", type=int, default=6)
    parser.add_argument("--message-bytes", type=int, default=45 << 20)
    args = parser.parse_args()
    server = subprocess.Popen(
        [args.binary, "serve", "--port", "0", "--http", "0", "--map", "fixed",
         "--hello-timeout-s", "3600", "--max-connections", str(args.connections + 16)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )
    try:
        for line in server.stdout:
            if line.startswith("http on "):
                host, port = line.split()[-1].rsplit(":", 1)
                break
        else:
            sys.exit("bw4t serve printed no `http on` line")
        port = int(port)
        open_websocket(host, port).close()  # warm up the web side
        before = settled_rss_kb(server.pid)
        sockets = [open_websocket(host, port) for _ in range(args.connections)]
        refused_while_sending = sum(not send_unfinished(s, args.message_bytes) for s in sockets)
        after = settled_rss_kb(server.pid)
        closed = sum(closed_by_server(s) for s in sockets)
        print(json.dumps({
            "connections": args.connections,
            "message_bytes": args.message_bytes,
            "rss_before_kb": before,
            "rss_after_kb": after,
            "kb_per_connection": round((after - before) / args.connections, 1),
            "refused_while_sending": refused_while_sending,
            "closed_by_server": closed,
        }))
        for s in sockets:
            s.close()
    finally:
        server.kill()
        server.wait()


if __name__ == "__main__":
    main()
