"""A socketcand relay for the tests of tampered input: it sits between a client node (a CANopen
master, the C controller) and the plant node's socketcand server, passes every message on both
ways unchanged, and changes one frame the server sends: the ``nth`` frame (1-based) of the
identifier ``frame_id`` is sent twice (``how="twice"``: a replayed frame, as a forger on the bus
would send it) or with one more byte (``how="longer"``; at most 8: a classical CAN frame). The
relay ends when either side hangs up. Protocol: docs/can-bench.md ("socketcand"): messages
``< ... >``, the server's frames ``< frame ID SEC.USEC HEXBYTES >``."""

from __future__ import annotations

import contextlib
import socket
import threading


class Relay:
    """Listen on 127.0.0.1 (``port``), relay one client to the server at ``server_port``."""

    def __init__(self, server_port: int, frame_id: int, nth: int, how: str) -> None:
        if how not in ("twice", "longer"):
            raise ValueError(f"how: 'twice' or 'longer', got {how!r}")
        self.frame_id, self.nth, self.how = frame_id, nth, how
        self.seen = 0  # frames of frame_id the server sent
        self.changed = 0  # frames changed
        self._listen = socket.create_server(("127.0.0.1", 0))
        self.port = int(self._listen.getsockname()[1])
        self._server_port = server_port
        self._thread = threading.Thread(target=self._run, name="scd relay", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        self._listen.settimeout(60.0)
        try:
            client, _ = self._listen.accept()
        except OSError:
            return
        finally:
            self._listen.close()
        server = socket.create_connection(("127.0.0.1", self._server_port))
        for s in (client, server):  # as the nodes' own sockets: no Nagle delay
            s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        up = threading.Thread(target=self._pump, args=(client, server, False), daemon=True)
        up.start()
        self._pump(server, client, True)
        up.join(5.0)

    def _pump(self, src: socket.socket, dst: socket.socket, from_server: bool) -> None:
        buf = b""
        try:
            while data := src.recv(65536):
                if not from_server:
                    dst.sendall(data)
                    continue
                buf += data
                out = []
                while (end := buf.find(b">")) >= 0:
                    out.append(self._change(buf[:end + 1]))
                    buf = buf[end + 1:]
                dst.sendall(b"".join(out))
        except OSError:
            pass
        for s in (src, dst):
            with contextlib.suppress(OSError):
                s.shutdown(socket.SHUT_RDWR)

    def _change(self, msg: bytes) -> bytes:
        """One message (and what came before it) as it goes on to the client."""
        lead, _, body = msg.partition(b"<")
        parts = body[:-1].split()
        if len(parts) != 4 or parts[0] != b"frame" or int(parts[1], 16) != self.frame_id:
            return msg
        self.seen += 1
        if self.seen != self.nth:
            return msg
        self.changed += 1
        if self.how == "twice":
            return msg + b" " + msg[len(lead):]
        return lead + b"< frame " + parts[1] + b" " + parts[2] + b" " + parts[3] + b"00 >"
