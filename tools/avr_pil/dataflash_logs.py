#!/usr/bin/env python3
"""The flight logs in an AT45DB321D image (avr_pil --dataflash FILE), read by the layout of docs/logging.md
("Log storage on the APM 2.5: the DataFlash"), independently of the firmware's driver:

  page 0          b"QLG1", erase generation (u16), then 8-byte slots from byte 8: start page (u16),
                  0xFFFF, start time UTC (u32); a start page of 0xFFFF ends the list (64 slots)
  pages 1..8191   512 data bytes, then the trailer: 0x5144, generation, the log's start page, the
                  page's sequence in the log, the bytes it holds (u16 each, little-endian)

A log is the run of pages from its start page whose trailers name it in sequence.

  dataflash_logs.py IMAGE list                 one line per log: id, start page, pages, bytes, time
  dataflash_logs.py IMAGE extract ID OUT.ulg   the log's bytes (ids 1..N, oldest first)
"""
import struct
import sys

PAGES, PAGE_SIZE, DATA_BYTES = 8192, 528, 512
MAGIC, TRAILER_MAGIC, NO_PAGE, MAX_LOGS = b"QLG1", 0x5144, 0xFFFF, 64


class ImageError(Exception):
    pass


def read_image(path):
    try:
        with open(path, "rb") as f:
            image = f.read()
    except OSError as e:
        raise ImageError(f"{path}: {e.strerror}")
    if len(image) != PAGES * PAGE_SIZE:
        raise ImageError(f"{path}: {len(image)} bytes, not an AT45DB321D image ({PAGES} x {PAGE_SIZE})")
    return image


def page(image, p):
    return image[p * PAGE_SIZE:(p + 1) * PAGE_SIZE]


def logs(image, path="image"):
    """[(id, start_page, time_utc, bytes)] in index order."""
    index = page(image, 0)
    if index[:4] != MAGIC:
        raise ImageError(f"{path}: page 0 does not start with {MAGIC!r} (no log index)")
    (generation,) = struct.unpack_from("<H", index, 4)
    found = []
    for slot in range(MAX_LOGS):
        start, _, time_utc = struct.unpack_from("<HHI", index, 8 + 8 * slot)
        if start == NO_PAGE:
            break
        data = bytearray()
        p = start
        while p < PAGES:
            magic, gen, log_start, sequence, used = struct.unpack_from("<5H", page(image, p), DATA_BYTES)
            if (magic, gen, log_start, sequence) != (TRAILER_MAGIC, generation, start, p - start) or used > DATA_BYTES:
                break
            data += page(image, p)[:used]
            p += 1
        found.append((slot + 1, start, time_utc, bytes(data)))
    return found


def main(argv):
    if len(argv) < 3 or argv[2] not in ("list", "extract") or (argv[2] == "extract" and len(argv) != 5):
        sys.stderr.write(__doc__)
        return 2
    try:
        image = read_image(argv[1])
        found = logs(image, argv[1])
    except ImageError as e:
        sys.stderr.write(f"dataflash_logs: {e}\n")
        return 1
    if argv[2] == "list":
        for log_id, start, time_utc, data in found:
            print(f"{log_id} start_page {start} pages {(len(data) + DATA_BYTES - 1) // DATA_BYTES} bytes {len(data)} time_utc {time_utc}")
        return 0
    wanted = int(argv[3])
    match = [data for log_id, _, _, data in found if log_id == wanted]
    if not match:
        sys.stderr.write(f"dataflash_logs: {argv[1]}: no log {wanted} (the image holds {len(found)})\n")
        return 1
    with open(argv[4], "wb") as f:
        f.write(match[0])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
