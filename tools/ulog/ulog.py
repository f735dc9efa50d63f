"""A reader of PX4 ULog files (https://docs.px4.io/main/en/dev_log/ulog_file_format.html), version 1.

Generic: any formats ('F', nested types and arrays of them), info ('I', 'M'), parameters ('P' and the
defaults 'Q'), subscriptions ('A', 'R'), data ('D'), logged strings ('L', 'C'), sync ('S'), dropouts ('O'),
and the appended-data flag of the 'B' message. A file that does not follow the format (a cut message, a
bad magic, a 'D' of no subscription, a size that does not fit its format, an unknown incompatible flag)
raises ULogError naming the file, the byte offset and the message.

    log = ULog("log_001.ulg")
    att = log.topic("vehicle_attitude")      # {"timestamp": array, "q": array (n, 4), ...}
    log.info["sys_name"], log.params["SYS_LOOP_HZ"], log.messages[0].text
"""
import struct
from collections import namedtuple

import numpy as np

MAGIC = b"ULog\x01\x12\x35"
SYNC_MAGIC = b"\x2f\x73\x13\x20\x25\x0c\xbb\x12"
INCOMPAT_DATA_APPENDED = 0x01  # incompat_flags[0], bit 0

BASIC_TYPES = {
    "int8_t": "<i1", "uint8_t": "<u1", "int16_t": "<i2", "uint16_t": "<u2", "int32_t": "<i4",
    "uint32_t": "<u4", "int64_t": "<i8", "uint64_t": "<u8", "float": "<f4", "double": "<f8",
    "bool": "?", "char": "S1",
}

Field = namedtuple("Field", "type array name")           # array: element count, 0 for a scalar
Subscription = namedtuple("Subscription", "name multi_id")
LoggedString = namedtuple("LoggedString", "timestamp level text tag")  # level: syslog '0'..'7' as int
Dropout = namedtuple("Dropout", "timestamp duration_ms")
ParamChange = namedtuple("ParamChange", "timestamp name value")


class ULogError(Exception):
    pass


def _text(raw):
    return raw.decode("utf-8", errors="replace")


def _split_type(type_text):
    """('float', 3) for 'float[3]', ('float', 0) for 'float'."""
    if type_text.endswith("]") and "[" in type_text:
        base, count = type_text[:-1].split("[", 1)
        return base, int(count)
    return type_text, 0


class ULog:
    def __init__(self, path):
        self.path = path
        with open(path, "rb") as f:
            self._b = f.read()
        self.version = 0
        self.timestamp = 0                 # header timestamp, us
        self.compat_flags = bytes(8)
        self.incompat_flags = bytes(8)
        self.appended_offsets = []
        self.formats = {}                  # name -> [Field]
        self.info = {}                     # key -> value ('I')
        self.info_multiple = {}            # key -> [[value, continuation...], ...] ('M')
        self.params = {}                   # the values at log start ('P' in the definitions)
        self.param_changes = []            # [ParamChange] ('P' in the data section, in file order)
        self.default_params = {}           # ('Q') default type bits -> {name: value}
        self.subscriptions = {}            # msg_id -> Subscription
        self.messages = []                 # [LoggedString] ('L' and 'C')
        self.dropouts = []                 # [Dropout]
        self.syncs = 0
        self.unknown_messages = 0          # skipped, as the format asks of readers
        self._payloads = {}                # msg_id -> [bytes]
        self._order = {}                   # msg_id -> [the record's place among all 'D' messages]
        self._dtypes = {}
        self._last_timestamp = 0
        self._data_count = 0
        self._parse()

    # ---- public ---------------------------------------------------------------------------------

    def topics(self):
        """[(name, multi_id)] of every subscription with data."""
        return sorted({(s.name, s.multi_id) for i, s in self.subscriptions.items() if self._payloads.get(i)})

    def has(self, name, multi_id=0):
        return (name, multi_id) in self.topics()

    def topic(self, name, multi_id=0):
        """The data of one topic instance as {field: numpy array}; array fields as (n, k) arrays, nested
        types as nested dicts; padding left out. KeyError when the log holds no such data."""
        ids = [i for i, s in self.subscriptions.items() if s == (name, multi_id) and self._payloads.get(i)]
        if not ids:
            raise KeyError(f"{self.path}: no data of topic '{name}' (instance {multi_id})")
        rows = np.frombuffer(b"".join(self._records(ids)), dtype=self._dtype(name))
        return self._columns(rows)

    def _records(self, ids):
        """The records of these msg_ids in file order (a topic subscribed again under another id)."""
        if len(ids) == 1:
            return self._payloads[ids[0]]
        merged = sorted((n, p) for i in ids for n, p in zip(self._order[i], self._payloads[i]))
        return [p for _, p in merged]

    # ---- parsing --------------------------------------------------------------------------------

    def _error(self, offset, what):
        raise ULogError(f"{self.path}: byte {offset}: {what}")

    def _parse(self):
        b = self._b
        if len(b) < 16:
            self._error(0, f"not a ULog file: {len(b)} bytes, shorter than the 16-byte header")
        if b[:7] != MAGIC:
            self._error(0, "not a ULog file: bad magic (expected 'ULog' 01 12 35)")
        self.version = b[7]
        (self.timestamp,) = struct.unpack_from("<Q", b, 8)
        pos, end, in_definitions, first = 16, len(b), True, True
        while pos < end:
            if pos + 3 > end:
                self._error(pos, f"truncated: a message header needs 3 bytes, the file ends after {end - pos}")
            size, kind = struct.unpack_from("<HB", b, pos)
            body = pos + 3
            stop = next((o for o in self.appended_offsets if o > pos), None)
            if stop is not None and body + size > stop:
                # The regular data ends before an appended block: the message cut there is not data.
                pos = stop
                continue
            if body + size > end:
                self._error(pos, f"truncated: message '{chr(kind)}' needs {size} bytes, the file ends after {end - body}")
            payload = b[body:body + size]
            if first and kind == ord("B"):
                self._flag_bits(pos, payload)
            first = False
            if kind in b"ADLCSOR":
                in_definitions = False
            self._message(pos, chr(kind), payload, in_definitions)
            pos = body + size

    def _need(self, offset, kind, payload, n):
        if len(payload) < n:
            self._error(offset, f"message '{kind}' has {len(payload)} bytes, needs at least {n}")

    def _flag_bits(self, offset, p):
        self._need(offset, "B", p, 40)
        self.compat_flags, self.incompat_flags = p[0:8], p[8:16]
        unknown = bytes([self.incompat_flags[0] & ~INCOMPAT_DATA_APPENDED & 0xFF]) + self.incompat_flags[1:]
        if any(unknown):
            self._error(offset, f"message 'B': unknown incompatible flags {self.incompat_flags.hex()}")
        if self.incompat_flags[0] & INCOMPAT_DATA_APPENDED:
            self.appended_offsets = [o for o in struct.unpack_from("<3Q", p, 16) if o]

    def _key_value(self, offset, kind, p, start):
        """'type name' key and the typed value of an 'I', 'M', 'P' or 'Q' message."""
        self._need(offset, kind, p, start + 1)
        n = p[start]
        self._need(offset, kind, p, start + 1 + n)
        key = _text(p[start + 1:start + 1 + n])
        raw = p[start + 1 + n:]
        try:
            type_text, name = key.split(" ", 1)
        except ValueError:
            self._error(offset, f"message '{kind}': key '{key}' is not 'type name'")
        base, count = _split_type(type_text)
        if base == "char":
            return name, _text(raw).rstrip("\x00")
        if base not in BASIC_TYPES:
            self._error(offset, f"message '{kind}' key '{key}': unknown type '{base}'")
        dt = np.dtype(BASIC_TYPES[base])
        want = dt.itemsize * max(count, 1)
        if len(raw) != want:
            self._error(offset, f"message '{kind}' key '{key}': value of {len(raw)} bytes, the type has {want}")
        values = np.frombuffer(raw, dtype=dt)
        value = values.tolist() if count else values[0].item()
        return name, value

    def _message(self, offset, kind, p, in_definitions):
        if kind == "B":
            return
        if kind == "F":
            self._format(offset, p)
        elif kind == "I":
            key, value = self._key_value(offset, kind, p, 0)
            self.info[key] = value
        elif kind == "M":
            self._need(offset, kind, p, 1)
            key, value = self._key_value(offset, kind, p, 1)
            parts = self.info_multiple.setdefault(key, [])
            if p[0] and parts:
                parts[-1].append(value)
            else:
                parts.append([value])
        elif kind == "P":
            key, value = self._key_value(offset, kind, p, 0)
            if in_definitions:
                self.params[key] = value
            else:
                self.param_changes.append(ParamChange(self._last_timestamp, key, value))
        elif kind == "Q":
            self._need(offset, kind, p, 1)
            key, value = self._key_value(offset, kind, p, 1)
            self.default_params.setdefault(p[0], {})[key] = value
        elif kind == "A":
            self._need(offset, kind, p, 4)
            multi_id, msg_id = struct.unpack_from("<BH", p, 0)
            name = _text(p[3:])
            if name not in self.formats:
                self._error(offset, f"message 'A': topic '{name}' has no format ('F') before it")
            self._dtype(name, offset)
            self.subscriptions[msg_id] = Subscription(name, multi_id)
        elif kind == "R":
            self._need(offset, kind, p, 2)
        elif kind == "D":
            self._data(offset, p)
        elif kind in "LC":
            tagged = kind == "C"
            head = 11 if tagged else 9
            self._need(offset, kind, p, head)
            level = p[0]
            tag = struct.unpack_from("<H", p, 1)[0] if tagged else None
            (t,) = struct.unpack_from("<Q", p, head - 8)
            text = _text(p[head:]).rstrip("\x00")
            self.messages.append(LoggedString(t, level - ord("0") if level >= ord("0") else level, text, tag))
        elif kind == "S":
            if p[:8] != SYNC_MAGIC:
                self._error(offset, f"message 'S': bad sync magic {p[:8].hex()}")
            self.syncs += 1
        elif kind == "O":
            self._need(offset, kind, p, 2)
            self.dropouts.append(Dropout(self._last_timestamp, struct.unpack_from("<H", p, 0)[0]))
        else:
            self.unknown_messages += 1

    def _format(self, offset, p):
        text = _text(p).rstrip("\x00")
        name, sep, rest = text.partition(":")
        if not sep or not name:
            self._error(offset, f"message 'F': '{text[:60]}' is not 'name:type field;...'")
        fields = []
        for item in filter(None, rest.split(";")):
            try:
                type_text, field = item.strip().split(" ", 1)
                base, count = _split_type(type_text)
            except ValueError:
                self._error(offset, f"message 'F' of '{name}': field '{item}' is not 'type name'")
            fields.append(Field(base, count, field))
        self.formats[name] = fields

    def _dtype(self, name, offset=None, depth=0):
        if name in self._dtypes:
            return self._dtypes[name]
        if name not in self.formats:
            self._error(offset or 0, f"type '{name}' has no format ('F')")
        if depth > 32:
            self._error(offset or 0, f"type '{name}': nested types too deep (a cycle?)")
        parts = []
        for f in self.formats[name]:
            if f.type in BASIC_TYPES:
                if f.type == "char" and f.array:
                    parts.append((f.name, f"S{f.array}"))
                else:
                    parts.append((f.name, BASIC_TYPES[f.type], (f.array,)) if f.array else (f.name, BASIC_TYPES[f.type]))
            else:
                sub = self._dtype(f.type, offset, depth + 1)
                parts.append((f.name, sub, (f.array,)) if f.array else (f.name, sub))
        dt = np.dtype(parts)
        self._dtypes[name] = dt
        return dt

    def _trailing_padding(self, name):
        n = 0
        for f in reversed(self.formats[name]):
            if not f.name.startswith("_padding"):
                break
            one = np.dtype(BASIC_TYPES[f.type]) if f.type in BASIC_TYPES else self._dtype(f.type)
            n += one.itemsize * max(f.array, 1)
        return n

    def _data(self, offset, p):
        self._need(offset, "D", p, 2)
        (msg_id,) = struct.unpack_from("<H", p, 0)
        sub = self.subscriptions.get(msg_id)
        if sub is None:
            self._error(offset, f"message 'D': msg_id {msg_id} has no subscription ('A') before it")
        dt = self._dtype(sub.name)
        body = p[2:]
        # A logger may leave out the padding at the end of a topic (PX4 does): fill it back.
        if len(body) != dt.itemsize:
            short = dt.itemsize - len(body)
            if short < 0 or short > self._trailing_padding(sub.name):
                self._error(offset, f"message 'D' of '{sub.name}': {len(body)} bytes of data, the format has {dt.itemsize}")
            body = body + bytes(short)
        self._payloads.setdefault(msg_id, []).append(body)
        self._order.setdefault(msg_id, []).append(self._data_count)
        self._data_count += 1
        if "timestamp" in dt.names and dt["timestamp"] == np.dtype("<u8"):
            t = np.frombuffer(body, dtype=dt, count=1)["timestamp"][0]
            if t > self._last_timestamp:
                self._last_timestamp = int(t)

    @staticmethod
    def _columns(rows):
        out = {}
        for name in rows.dtype.names:
            if name.startswith("_padding"):
                continue
            col = rows[name]
            if col.dtype.names is not None:
                out[name] = ULog._columns(col)
            elif col.dtype.kind == "S":
                out[name] = np.array([v.decode("utf-8", errors="replace") for v in col])
            else:
                out[name] = np.array(col)
        return out


def dump(log, records=False, out=None):
    """The text ulog_dump prints (C++ reader): topics and counts, info, parameters, strings; with records
    every record, floats as the hex of their bits, so the two readers' outputs compare exactly."""
    import sys
    w = (out or sys.stdout).write
    for name, multi_id in log.topics():
        w(f"topic {name} {multi_id} {len(log.topic(name, multi_id)['timestamp'])}\n")
    for k in sorted(log.info):
        v = log.info[k]
        w(f"info {k} {v if isinstance(v, str) else _number_text(v)}\n")
    for k in sorted(log.params):
        w(f"param {k} {float(log.params[k]):.9g}\n")
    for c in log.param_changes:
        w(f"param_change {c.name} {float(c.value):.9g}\n")
    for m in log.messages:
        w(f"string {m.timestamp} {m.level} {m.text}\n")
    if not records:
        return
    for name, multi_id in log.topics():
        ids = [i for i, s in log.subscriptions.items() if s == (name, multi_id) and log._payloads.get(i)]
        for raw in log._records(ids):
            w(f"{name} {multi_id}:{''.join(' ' + v for v in _record_parts(log, name, raw))}\n")


def _number_text(v):
    return repr(v) if isinstance(v, float) else str(v)


def _record_parts(log, type_name, raw):
    parts = []
    at = 0
    for f in log.formats[type_name]:
        n = max(f.array, 1)
        padding = f.name.startswith("_padding")
        if f.type == "char" and f.array:
            if not padding:
                parts.append('"' + raw[at:at + n].split(b"\0")[0].decode("utf-8", errors="replace") + '"')
            at += n
        elif f.type in BASIC_TYPES:
            size = np.dtype(BASIC_TYPES[f.type]).itemsize
            for k in range(n):
                b = raw[at:at + size]
                if not padding:
                    if f.type in ("float", "double"):
                        parts.append(f"{int.from_bytes(b, 'little'):0{2 * size}x}")
                    else:
                        parts.append(str(int(np.frombuffer(b, dtype=BASIC_TYPES[f.type].replace("S1", "u1"))[0])))
                at += size
        else:
            size = log._dtype(f.type).itemsize
            for k in range(n):
                parts.extend(_record_parts(log, f.type, raw[at:at + size]))
                at += size
    return parts


if __name__ == "__main__":
    import sys
    args = [a for a in sys.argv[1:] if a != "--records"]
    if len(args) != 1:
        raise SystemExit("usage: ulog.py [--records] LOG.ulg")
    try:
        dump(ULog(args[0]), records="--records" in sys.argv)
    except ULogError as e:
        raise SystemExit(f"ulog.py: {e}")
