"""A headless Foxglove WebSocket client for the tests (Python ``websockets``).

It offers the subprotocols ``foxglove.sdk.v1`` (what foxglove-sdk 0.30 speaks) and
``foxglove.websocket.v1``, subscribes to every channel the server advertises, and keeps each
message as (topic, log time ns, payload bytes). Message data frames are binary: opcode 1, the
subscription id (uint32 LE), the log time (uint64 LE), then the payload.
"""

from __future__ import annotations

import asyncio
import json
import struct
import threading
from typing import Any

SUBPROTOCOLS = ('foxglove.sdk.v1', 'foxglove.websocket.v1')


class FoxgloveClient:
    """Connects to ``url`` in a thread until ``stop``."""

    def __init__(self, url: str) -> None:
        self.url = url
        self.subprotocol: str | None = None
        self.server_info: dict[str, Any] = {}
        self.channels: dict[int, dict[str, Any]] = {}
        self.messages: list[tuple[str, int, bytes]] = []
        self.subscribed = threading.Event()
        self.error: BaseException | None = None
        self.closed_by_server = False
        self._stop = False
        self._thread = threading.Thread(target=self._main, daemon=True)

    def start(self) -> FoxgloveClient:
        """Connect and subscribe (in the background)."""
        self._thread.start()
        return self

    def stop(self) -> None:
        """Disconnect."""
        self._stop = True
        self._thread.join(timeout=10)

    def _main(self) -> None:
        from websockets.exceptions import ConnectionClosedOK
        try:
            asyncio.run(self._run())
        except ConnectionClosedOK:      # the server stopped with its run: a normal end
            self.closed_by_server = True
        except BaseException as exc:  # noqa: BLE001 - handed to the test
            self.error = exc

    async def _run(self) -> None:
        from websockets.asyncio.client import connect
        async with connect(self.url, subprotocols=list(SUBPROTOCOLS),  # type: ignore[arg-type]
                           max_size=None) as ws:
            self.subprotocol = ws.subprotocol
            subs: dict[int, str] = {}
            while not self._stop:
                try:
                    frame = await asyncio.wait_for(ws.recv(), 0.2)
                except TimeoutError:
                    continue
                if isinstance(frame, str):
                    msg = json.loads(frame)
                    if msg['op'] == 'serverInfo':
                        self.server_info = msg
                    elif msg['op'] == 'advertise':
                        new = []
                        for ch in msg['channels']:
                            self.channels[ch['id']] = ch
                            sid = len(subs) + 1
                            subs[sid] = ch['topic']
                            new.append({'id': sid, 'channelId': ch['id']})
                        await ws.send(json.dumps({'op': 'subscribe', 'subscriptions': new}))
                        self.subscribed.set()
                elif frame[0] == 1:
                    sid, t_ns = struct.unpack_from('<IQ', frame, 1)
                    self.messages.append((subs[sid], t_ns, bytes(frame[13:])))
