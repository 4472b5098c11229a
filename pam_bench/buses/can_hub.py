"""A CAN bus between processes on one machine: a hub that speaks socketcand's protocol on
loopback.

A lab's bench has a CAN interface (``socketcan``: ``can0``); this machine's kernel has no vcan,
python-can's ``virtual`` bus reaches only one process, and its ``udp_multicast`` bus sends to a
multicast group on whatever interface the route picks, off this machine. So the emulated bench
and the tests put the CAN bus behind a TCP hub on 127.0.0.1 that python-can's ``socketcand``
interface connects to: every frame a client sends goes to every other client, as on a bus (a
sender does not hear itself, as on socketcan without loopback).

The part of socketcand's ASCII protocol the hub speaks (what python-can sends and expects)::

    hub: < hi >                 client: < open CHANNEL >     hub: < ok >
    client: < rawmode >         hub: < ok >
    client: < send ID LEN B0 B1 ... >     (hex, ID of 3 digits: standard, 8: extended)
    hub to the others: < frame ID SECONDS.MICROSECONDS DATA >   (DATA: hex bytes, no spaces)

Frames are sent to a client only after its handshake has been answered in full (python-can
reads each reply of the handshake on its own).
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Iterator
from typing import Any

from pam_bench.buses.errors import BusUnreachable

__all__ = ['CanHub', 'can_hub', 'bus_config']


class _Client:
    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.ready = False
        self.lock = threading.Lock()

    def send(self, text: str) -> None:
        with self.lock:
            self.sock.sendall(text.encode('ascii'))


class CanHub:
    """The hub (module docstring): ``start`` serves 127.0.0.1:``port`` (0: a free port) in a
    thread; ``stop`` closes it. ``frames`` counts the frames relayed."""

    def __init__(self, port: int = 0, host: str = '127.0.0.1') -> None:
        self.host = host
        self._server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._server.bind((host, port))
        except OSError as exc:
            self._server.close()
            raise BusUnreachable(f'CAN hub: cannot listen on {host}:{port}: '
                                 f'{exc.strerror or exc}') from None
        self.port = self._server.getsockname()[1]
        self._clients: list[_Client] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.frames = 0

    def start(self) -> CanHub:
        """Accept clients in a thread; returns self."""
        self._server.listen(16)
        threading.Thread(target=self._accept, daemon=True, name='can-hub').start()
        return self

    def stop(self) -> None:
        """Close the hub and every client connection."""
        self._stop.set()
        with contextlib.suppress(OSError):
            self._server.close()
        with self._lock:
            for c in self._clients:
                with contextlib.suppress(OSError):
                    c.sock.close()
            self._clients.clear()

    def _accept(self) -> None:
        while not self._stop.is_set():
            try:
                sock, _ = self._server.accept()
            except OSError:
                return
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            client = _Client(sock)
            with self._lock:
                self._clients.append(client)
            threading.Thread(target=self._serve, args=(client,), daemon=True,
                             name='can-hub-client').start()

    def _serve(self, client: _Client) -> None:
        buffer = ''
        try:
            client.send('< hi >')
            while not self._stop.is_set():
                data = client.sock.recv(4096)
                if not data:
                    break
                buffer += data.decode('ascii', errors='replace')
                while '>' in buffer:
                    start = buffer.find('<')
                    end = buffer.find('>')
                    message, buffer = buffer[start + 1:end].split(), buffer[end + 1:]
                    if start < 0 or start > end or not message:
                        continue
                    self._handle(client, message)
        except OSError:
            pass
        finally:
            with self._lock:
                if client in self._clients:
                    self._clients.remove(client)
            with contextlib.suppress(OSError):
                client.sock.close()

    def _handle(self, client: _Client, message: list[str]) -> None:
        verb = message[0]
        if verb == 'open':
            client.send('< ok >')
        elif verb == 'rawmode':
            client.send('< ok >')
            time.sleep(0.02)                 # its handshake read comes first, on its own
            client.ready = True
        elif verb == 'send' and len(message) >= 3:
            can_id, length = message[1], int(message[2], 16)
            data = ''.join(f'{int(b, 16):02X}' for b in message[3:3 + length])
            now = time.time()
            frame = f'< frame {can_id} {int(now)}.{int(now % 1 * 1e6):06d} {data} >'
            with self._lock:
                others = [c for c in self._clients if c is not client and c.ready]
            self.frames += 1
            for other in others:
                with contextlib.suppress(OSError):
                    other.send(frame)


@contextlib.contextmanager
def can_hub(port: int = 0) -> Iterator[CanHub]:
    """A running hub for the ``with`` block."""
    hub = CanHub(port).start()
    try:
        yield hub
    finally:
        hub.stop()


def bus_config(interface: str, channel: str, port: int = 0) -> dict[str, Any]:
    """The python-can (and canopen ``Network.connect``) keywords of a bus: ``socketcan`` and
    ``channel`` (a lab's ``can0``), or ``socketcand`` on the hub at 127.0.0.1:``port``."""
    if interface == 'socketcand':
        return {'interface': 'socketcand', 'channel': channel, 'host': '127.0.0.1',
                'port': port, 'tcp_tune': True}
    return {'interface': interface, 'channel': channel}
