"""A DAQ's Modbus register map: which register carries which signal of the driver contract.

A map is a YAML file, checked as strictly as every other (unknown, misspelt or duplicate keys,
bad values and overlapping registers are one line naming them)::

    name: generic DAQ                   # shown in diagnostics
    device_id: 1                        # Modbus unit / device id
    word_order: big                     # 32-bit values: high word first (big) or low first
    address_space: split                # input and holding registers apart (split) or one
                                        # space both read functions reach (unified: LabJack)
    watchdog_s: 0.1                     # the device's own host-loss action: outputs to 0
                                        # after this long without a write (0: it has none)
    device_registers:                   # what else the device serves, and how (optional)
      - {name: AIN, address: 0, count: 28, access: r}
    channels:
      - {signal: load_cell_1.force, register: input, address: 0, type: float32,
         scale: 1.0, offset: 0.0, unit: N, low: -2000.0, high: 2000.0, access: r}

Each channel converts between the raw register value r and the signal s in SI units::

    s = scale * r + offset            (read: input signals)
    r = (s - offset) / scale          (write: output signals, rounded for integer types)

``low``/``high`` bound a plausible reading (a value outside is rejected, as a broken wire or
a flipped register would give) and an output (a command outside is refused, never clamped
into the register). The signals are those of ``SIGNALS``; an output signal lives in holding
registers, an input one in input or holding registers. The inputs are read in as few requests
as their addresses allow (``blocks``: the generic map needs one), the outputs written in one
request per block. ``access`` says what the device lets a master do with a channel's registers
(``r``, ``w``, ``rw``; default: ``r`` for an input, ``rw`` for an output): an emulated device
refuses the rest as the real one does (``twin.modbus_server``), and ``device_registers`` are
the device's other registers a master may touch (the emulation serves them as zeros).
"""

from __future__ import annotations

import dataclasses
import math
import pathlib
import struct
from typing import Any

from pam_bench.buses.errors import MapError
from pam_bench.vocabulary.errors import PamBenchError, quoted
from pam_bench.vocabulary.params import check_known
from pam_bench.vocabulary.yaml_io import read_yaml

__all__ = ['SIGNALS', 'TYPES', 'ACCESS', 'Channel', 'Block', 'DeviceRegisters', 'RegisterMap',
           'load_register_map', 'MAX_BLOCK']

SIGNALS: dict[str, tuple[str, str]] = {
    'valve_1.voltage': ('output', 'V'), 'valve_2.voltage': ('output', 'V'),
    'valve_1.pressure': ('input', 'Pa'), 'valve_2.pressure': ('input', 'Pa'),
    'load_cell_1.force': ('input', 'N'), 'load_cell_2.force': ('input', 'N'),
    'encoder.angle': ('input', 'rad'),
}
"""Signal -> (direction, SI unit): the driver contract's values a DAQ may carry (the valve's
command voltage, its absolute output pressure, a load cell's force, the pulley angle)."""

TYPES: dict[str, tuple[str, int]] = {
    'uint16': ('H', 1), 'int16': ('h', 1), 'uint32': ('I', 2), 'int32': ('i', 2),
    'float32': ('f', 2),
}
"""Register data type -> (struct code, registers)."""

MAX_BLOCK = 125
"""Most registers one Modbus read request returns (the protocol's limit)."""

_MAP_KEYS = ('name', 'device_id', 'word_order', 'channels', 'description', 'address_space',
             'watchdog_s', 'device_registers')
_CHANNEL_KEYS = ('signal', 'register', 'address', 'type', 'scale', 'offset', 'unit', 'low',
                 'high', 'access')
_DEVICE_KEYS = ('name', 'address', 'count', 'access', 'register')
ACCESS = ('r', 'w', 'rw')


@dataclasses.dataclass(frozen=True)
class Channel:
    """One signal in registers: where (``register`` 'input' or 'holding', ``address``), how
    (``type``, ``scale``, ``offset``: s = scale r + offset), its unit and plausible range."""

    signal: str
    register: str
    address: int
    type: str
    scale: float
    offset: float
    unit: str
    low: float
    high: float
    access: str = 'r'

    @property
    def count(self) -> int:
        """Registers it spans."""
        return TYPES[self.type][1]

    @property
    def output(self) -> bool:
        """Whether the driver writes it (a command)."""
        return SIGNALS[self.signal][0] == 'output'


@dataclasses.dataclass(frozen=True)
class Block:
    """Consecutive registers of one kind read (or written) in one request."""

    register: str
    address: int
    count: int
    channels: tuple[Channel, ...]


@dataclasses.dataclass(frozen=True)
class DeviceRegisters:
    """Registers of the device beyond the map's channels: ``count`` from ``address`` of kind
    ``register``, with what a master may do (``access``)."""

    name: str
    register: str
    address: int
    count: int
    access: str


@dataclasses.dataclass(frozen=True)
class RegisterMap:
    """A checked register map (module docstring)."""

    name: str
    device_id: int
    word_order: str
    channels: tuple[Channel, ...]
    address_space: str = 'split'
    watchdog_s: float = 0.0
    device_registers: tuple[DeviceRegisters, ...] = ()

    def access_of(self, register: str, address: int) -> str:
        """What a master may do with one register ('' when the device has none there): in a
        unified space both kinds name the same register."""
        for c in self.channels:
            if (self.address_space == 'unified' or c.register == register) and \
                    c.address <= address < c.address + c.count:
                return c.access
        for d in self.device_registers:
            if (self.address_space == 'unified' or d.register == register) and \
                    d.address <= address < d.address + d.count:
                return d.access
        return ''

    def channel(self, signal: str) -> Channel | None:
        """The channel carrying ``signal`` (None: this map has none)."""
        return next((c for c in self.channels if c.signal == signal), None)

    @property
    def inputs(self) -> list[Channel]:
        """The channels the driver reads."""
        return [c for c in self.channels if not c.output]

    @property
    def outputs(self) -> list[Channel]:
        """The channels the driver writes."""
        return [c for c in self.channels if c.output]

    def blocks(self, output: bool) -> list[Block]:
        """The requests that read the inputs (or write the outputs): channels of one register
        kind grouped while they fit in one request of at most ``MAX_BLOCK`` registers and the
        gap between them is at most 8 registers (read along)."""
        chans = sorted(self.outputs if output else self.inputs,
                       key=lambda c: (c.register, c.address))
        out: list[Block] = []
        group: list[Channel] = []
        for c in chans:
            if group and (c.register != group[0].register
                          or c.address + c.count - group[0].address > MAX_BLOCK
                          or c.address - (group[-1].address + group[-1].count) > 8
                          or output and c.address != group[-1].address + group[-1].count):
                out.append(_block(group))
                group = []
            group.append(c)
        if group:
            out.append(_block(group))
        return out

    # --- raw <-> SI ---------------------------------------------------------------------
    def _words(self, raw: float, c: Channel) -> list[int]:
        code, count = TYPES[c.type]
        data = struct.pack(f'>{code}', raw)
        words = [int.from_bytes(data[2 * k:2 * k + 2], 'big') for k in range(count)]
        return words if self.word_order == 'big' else words[::-1]

    def _value(self, words: list[int], c: Channel) -> float:
        code, _ = TYPES[c.type]
        ordered = words if self.word_order == 'big' else words[::-1]
        data = b''.join(w.to_bytes(2, 'big') for w in ordered)
        return float(struct.unpack(f'>{code}', data)[0])

    def encode(self, c: Channel, value_si: float) -> list[int]:
        """The registers that carry ``value_si`` on ``c`` (outputs; inputs too, for a server
        that serves a simulated bench).

        Raises:
            ValueError: the value is not finite, outside [low, high], or does not fit the
                register type.
        """
        if not math.isfinite(value_si) or not c.low <= value_si <= c.high:
            raise ValueError(f'{c.signal} {value_si!r} {c.unit} is outside '
                             f'[{c.low:g}, {c.high:g}]')
        raw = (value_si - c.offset) / c.scale
        if c.type != 'float32':
            raw = round(raw)
            lo, hi = _int_range(c.type)
            if not lo <= raw <= hi:
                raise ValueError(f'{c.signal} {value_si!r} {c.unit} does not fit {c.type}')
        return self._words(raw, c)

    def decode(self, c: Channel, words: list[int]) -> float:
        """The signal ``c`` carries in ``words`` (SI; NaN when not finite or outside
        [low, high]: a reading to reject)."""
        value = c.scale * self._value(words, c) + c.offset
        return value if math.isfinite(value) and c.low <= value <= c.high else math.nan

    def decode_block(self, block: Block, words: list[int]) -> dict[str, float]:
        """Every signal of a block read as ``words`` (``decode``)."""
        return {c.signal: self.decode(c, words[c.address - block.address:
                                                c.address - block.address + c.count])
                for c in block.channels}


def _int_range(kind: str) -> tuple[int, int]:
    bits = 16 if kind.endswith('16') else 32
    return (0, 2**bits - 1) if kind.startswith('u') else (-2**(bits - 1), 2**(bits - 1) - 1)


def _block(group: list[Channel]) -> Block:
    start = group[0].address
    end = max(c.address + c.count for c in group)
    return Block(group[0].register, start, end - start, tuple(group))


def _number(entry: dict[str, Any], key: str, where: str, default: float | None = None) -> float:
    value = entry.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not math.isfinite(float(value)):
        raise MapError(f'{where}: {key} must be a finite number, not {value!r}')
    return float(value)


def parse_register_map(data: Any, where: str) -> RegisterMap:
    """Check a register map's mapping (module docstring).

    Raises:
        MapError: names the key or the channel that is wrong.
    """
    if not isinstance(data, dict):
        raise MapError(f'{where}: a register map is a mapping with channels')
    try:
        check_known(data, _MAP_KEYS, where)
    except PamBenchError as exc:
        raise MapError(str(exc)) from None
    word_order = data.get('word_order', 'big')
    if word_order not in ('big', 'little'):
        raise MapError(f'{where}: word_order must be big or little, not {word_order!r}')
    device_id = data.get('device_id', 1)
    if isinstance(device_id, bool) or not isinstance(device_id, int) or \
            not 0 <= device_id <= 247:
        raise MapError(f'{where}: device_id must be an integer 0..247')
    entries = data.get('channels')
    if not isinstance(entries, list) or not entries:
        raise MapError(f'{where}: channels must be a non-empty list')
    channels: list[Channel] = []
    for k, entry in enumerate(entries):
        here = f'{where}: channels[{k}]'
        if not isinstance(entry, dict):
            raise MapError(f'{here} must be a mapping')
        try:
            check_known(entry, _CHANNEL_KEYS, here)
        except PamBenchError as exc:
            raise MapError(str(exc)) from None
        signal = entry.get('signal')
        if signal not in SIGNALS:
            raise MapError(f'{here}: unknown signal {quoted(str(signal))} (one of '
                           f'{", ".join(SIGNALS)})')
        direction, unit = SIGNALS[signal]
        register = entry.get('register', 'holding' if direction == 'output' else 'input')
        if register not in ('input', 'holding'):
            raise MapError(f'{here}: register must be input or holding, not {register!r}')
        if direction == 'output' and register != 'holding':
            raise MapError(f'{here}: {signal} is written: it needs holding registers')
        address = entry.get('address')
        if isinstance(address, bool) or not isinstance(address, int) or \
                not 0 <= address <= 65535:
            raise MapError(f'{here}: address must be an integer 0..65535')
        kind = entry.get('type', 'float32')
        if kind not in TYPES:
            raise MapError(f'{here}: type must be one of {", ".join(TYPES)}, not {kind!r}')
        if entry.get('unit', unit) != unit:
            raise MapError(f'{here}: {signal} is in {unit}, not {entry.get("unit")!r} (scale '
                           'and offset convert the register to it)')
        scale = _number(entry, 'scale', here, 1.0)
        if scale == 0.0:
            raise MapError(f'{here}: scale must not be 0')
        low, high = _number(entry, 'low', here), _number(entry, 'high', here)
        if not low < high:
            raise MapError(f'{here}: low must be below high')
        access = entry.get('access', 'rw' if direction == 'output' else 'r')
        if access not in ACCESS or (direction == 'output' and 'w' not in access) or \
                (direction == 'input' and 'r' not in access):
            raise MapError(f'{here}: access {access!r} does not let the driver '
                           f'{"write" if direction == "output" else "read"} {signal} (one of '
                           f'{", ".join(ACCESS)})')
        channels.append(Channel(signal, register, address, kind, scale,
                                _number(entry, 'offset', here, 0.0), unit, low, high, access))
    seen: dict[str, int] = {}
    for k, c in enumerate(channels):
        if c.signal in seen:
            raise MapError(f'{where}: channels[{k}] repeats signal {c.signal} '
                           f'(channels[{seen[c.signal]}])')
        seen[c.signal] = k
    taken: dict[tuple[str, int], str] = {}
    for c in channels:
        for a in range(c.address, c.address + c.count):
            other = taken.get((c.register, a))
            if other is not None:
                raise MapError(f'{where}: {c.signal} and {other} share {c.register} register '
                               f'{a}')
            taken[(c.register, a)] = c.signal
    space = data.get('address_space', 'split')
    if space not in ('split', 'unified'):
        raise MapError(f'{where}: address_space must be split or unified, not {space!r}')
    watchdog = _number(data, 'watchdog_s', where, 0.0)
    if not 0.0 <= watchdog <= 3600.0:
        raise MapError(f'{where}: watchdog_s must be in [0, 3600] s (0: the device has none)')
    extra = data.get('device_registers', [])
    if not isinstance(extra, list):
        raise MapError(f'{where}: device_registers must be a list')
    device: list[DeviceRegisters] = []
    for k, entry in enumerate(extra):
        here = f'{where}: device_registers[{k}]'
        if not isinstance(entry, dict):
            raise MapError(f'{here} must be a mapping')
        try:
            check_known(entry, _DEVICE_KEYS, here)
        except PamBenchError as exc:
            raise MapError(str(exc)) from None
        start, count = entry.get('address'), entry.get('count')
        if isinstance(start, bool) or not isinstance(start, int) or \
                isinstance(count, bool) or not isinstance(count, int) or \
                not (0 <= start and 1 <= count and start + count <= 65536):
            raise MapError(f'{here}: address and count must be integers within 0..65535')
        if entry.get('access') not in ACCESS:
            raise MapError(f'{here}: access must be one of {", ".join(ACCESS)}')
        register = entry.get('register', 'holding')
        if register not in ('input', 'holding'):
            raise MapError(f'{here}: register must be input or holding')
        device.append(DeviceRegisters(str(entry.get('name', f'registers {start}')), register,
                                      start, count, entry['access']))
    return RegisterMap(str(data.get('name', where)), device_id, word_order, tuple(channels),
                       space, watchdog, tuple(device))


def load_register_map(path: str | pathlib.Path) -> RegisterMap:
    """Read and check a register map file (a bare name: one of config/buses/).

    Raises:
        MapError: the map is wrong (names the key).
        InputError: the file is missing, unreadable or not YAML.
    """
    p = pathlib.Path(path)
    if not p.suffix and not p.exists():
        from pam_bench.config.paths import config_dir
        p = config_dir() / 'buses' / f'{p.name}.yaml'
    return parse_register_map(read_yaml(p), str(path))
