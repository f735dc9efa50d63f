"""The Python ULog reader (tools/ulog/ulog.py) on logs composed here byte by byte from the format's
specification (docs.px4.io "ULog File Format"), the same cases as test_ulog_reader.cpp for the C++ one.

    /usr/bin/python3 -m unittest -v test_ulog_py      (from tests/ulog; ctest ulog_reader_python)
"""
import os
import struct
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "ulog"))
from ulog import ULog, ULogError  # noqa: E402

SYNC = bytes([0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12])


def message(kind, payload):
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def key_value(key, value):
    return bytes([len(key)]) + key.encode() + value


def flags(incompat0=0, appended=0):
    return bytes(8) + bytes([incompat0]) + bytes(7) + struct.pack("<3Q", appended, 0, 0)


HEADER = b"ULog\x01\x12\x35\x01" + struct.pack("<Q", 1234)


def definitions():
    return (HEADER + message("B", flags())
            + message("F", b"pair:float a;int16_t b;")
            + message("F", b"sample:uint64_t timestamp;float[3] v;pair[2] p;uint8_t flag;uint8_t[3] _padding0;")
            + message("I", key_value("char[11] sys_name", b"quad-stereo"))
            + message("I", key_value("uint32_t loop_hz", struct.pack("<I", 400)))
            + message("P", key_value("float SYS_LOOP_HZ", struct.pack("<f", 400.0)))
            + message("A", struct.pack("<BH", 0, 7) + b"sample"))


def sample(t, v0, msg_id=7):
    """A record of 'sample' without its 3 padding bytes (a logger may leave them out)."""
    return struct.pack("<HQfff", msg_id, t, v0, 2.0, 3.0) + struct.pack("<fhfhB", 0.5, -3, 1.5, 4, 1)


class Reader(unittest.TestCase):
    def read(self, data):
        fd, path = tempfile.mkstemp(suffix=".ulg")
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        try:
            return ULog(path)
        finally:
            os.remove(path)

    def error(self, data):
        with self.assertRaises(ULogError) as cm:
            self.read(data)
        return str(cm.exception)

    def test_every_kind_of_message(self):
        log = self.read(definitions() + message("D", sample(1000, 1.0))
                        + message("P", key_value("float SYS_LOOP_HZ", struct.pack("<f", 200.0)))
                        + message("L", b"4" + struct.pack("<Q", 1500) + b"mode: AUTO")
                        + message("S", SYNC) + message("O", struct.pack("<H", 25))
                        + message("Z", b"a message type the reader does not know")
                        + message("D", sample(2000, -1.0)))
        self.assertEqual(log.timestamp, 1234)
        self.assertEqual(log.info["sys_name"], "quad-stereo")
        self.assertEqual(log.info["loop_hz"], 400)
        self.assertEqual(log.params["SYS_LOOP_HZ"], 400.0)
        self.assertEqual([(c.timestamp, c.name, c.value) for c in log.param_changes], [(1000, "SYS_LOOP_HZ", 200.0)])
        self.assertEqual([(m.timestamp, m.level, m.text) for m in log.messages], [(1500, 4, "mode: AUTO")])
        self.assertEqual(log.syncs, 1)
        self.assertEqual([(d.timestamp, d.duration_ms) for d in log.dropouts], [(1000, 25)])
        self.assertEqual(log.unknown_messages, 1)
        s = log.topic("sample")
        self.assertEqual(list(s["timestamp"]), [1000, 2000])
        self.assertEqual(s["v"].shape, (2, 3))
        self.assertEqual(list(s["v"][:, 0]), [1.0, -1.0])
        self.assertEqual(list(s["p"]["a"][0]), [0.5, 1.5])
        self.assertEqual(list(s["p"]["b"][0]), [-3, 4])
        self.assertEqual(list(s["flag"]), [1, 1])
        self.assertNotIn("_padding0", s)
        with self.assertRaises(KeyError):
            log.topic("other")

    def test_appended_data_past_a_cut_message(self):
        head = definitions() + message("D", sample(1000, 1.0)) + message("D", sample(2000, 2.0))[:10]
        data = bytearray(head + message("D", sample(3000, 3.0)))
        data[16 + 3:16 + 3 + 40] = flags(1, len(head))
        log = self.read(bytes(data))
        self.assertEqual(log.appended_offsets, [len(head)])
        self.assertEqual(list(log.topic("sample")["timestamp"]), [1000, 3000])

    def test_errors_name_the_byte_offset_and_the_message(self):
        d_at = len(definitions())
        good = definitions() + message("D", sample(1000, 1.0))
        self.assertIn(f"byte {d_at}: truncated: message 'D'", self.error(good[:-5]))
        self.assertIn("byte 0: not a ULog file", self.error(b"UXog" + good[4:]))
        self.assertIn(f"byte {d_at}: message 'D': msg_id 9 has no subscription",
                      self.error(definitions() + message("D", sample(1000, 1.0, msg_id=9))))
        self.assertIn("message 'D' of 'sample': 41 bytes of data, the format has 36",
                      self.error(definitions() + message("D", sample(1000, 1.0) + bytes(8))))
        self.assertIn("byte 16: message 'B': unknown incompatible flags", self.error(HEADER + message("B", flags(2))))
        self.assertIn("byte 16: message 'A': topic 'missing' has no format",
                      self.error(HEADER + message("A", struct.pack("<BH", 0, 1) + b"missing")))
        self.assertIn(f"byte {d_at}: message 'S': bad sync magic", self.error(definitions() + message("S", bytes(8))))
        self.assertIn("shorter than the 16-byte header", self.error(b""))


if __name__ == "__main__":
    unittest.main()
