#!/usr/bin/env python3
"""The flight logs in an AT45DB321D image (avr_pil --dataflash FILE), read by the layout of docs/logging.md
("Log storage on the APM 2.5: the DataFlash"), independently of the firmware's driver:

  pages 0, 1      two copies of the index: b"QLG2", erase generation (u16), the next log's serial (u16),
                  64 slots of 8 bytes from byte 8 (the slot of serial s is s mod 64: serial, first page
                  (u16), start time UTC (u32); an unused slot is 0xFF), the update count (u16) at byte
                  520 and a check (u16) at 522: 0x5149 plus every u16 word of bytes 4..521, modulo 2^16.
                  The index is the valid copy with the higher update count.
  pages 2..N-1    the ring of log data: 512 data bytes, then the trailer: check (0x5144 plus the four
                  words that follow, modulo 2^16), generation, the log's serial, the page's sequence in
                  the log, the bytes it holds (u16 each, little-endian)

A log is the run of pages from its first page, around the ring, whose trailers name it in sequence. The
logs held are, going back from the index's next serial, the newest whose first page names it, then every
older one while its slot holds it and its first page names it (the writer drops the oldest log when it
programs that log's first page). The image's size gives N (the full part: 8192 pages).

  dataflash_logs.py IMAGE list                 one line per log: id, start page, pages, bytes, time
  dataflash_logs.py IMAGE extract ID OUT.ulg   the log's bytes (ids 1..N, oldest first)
"""
import struct
import sys

PAGE_SIZE, DATA_BYTES, FIRST_DATA_PAGE, SLOTS = 528, 512, 2, 64
MAGIC, TRAILER_SEED, INDEX_SEED = b"QLG2", 0x5144, 0x5149


class ImageError(Exception):
    pass


def read_image(path):
    try:
        with open(path, "rb") as f:
            image = f.read()
    except OSError as e:
        raise ImageError(f"{path}: {e.strerror}")
    if len(image) % PAGE_SIZE != 0 or len(image) // PAGE_SIZE <= FIRST_DATA_PAGE:
        raise ImageError(f"{path}: {len(image)} bytes, not an AT45DB321D image (pages of {PAGE_SIZE} bytes)")
    return image


def page(image, p):
    return image[p * PAGE_SIZE:(p + 1) * PAGE_SIZE]


def index_copy(image, copy):
    """(generation, next serial, update count, slots by serial) of a valid copy, else None."""
    p = page(image, copy)
    if p[:4] != MAGIC:
        return None
    words = struct.unpack_from("<259H", p, 4)
    (check,) = struct.unpack_from("<H", p, 522)
    if (INDEX_SEED + sum(words)) & 0xFFFF != check:
        return None
    generation, next_serial = words[0], words[1]
    slots = {}
    for slot in range(SLOTS):
        serial, start, time_utc = struct.unpack_from("<HHI", p, 8 + 8 * slot)
        if serial % SLOTS == slot:
            slots[serial] = (start, time_utc)
    return generation, next_serial, words[258], slots


def logs(image, path="image"):
    """[(id, start_page, time_utc, bytes)], oldest first."""
    pages = len(image) // PAGE_SIZE
    ring = pages - FIRST_DATA_PAGE
    copies = [c for c in (index_copy(image, 0), index_copy(image, 1)) if c is not None]
    if not copies:
        raise ImageError(f"{path}: neither page 0 nor page 1 is a whole index ({MAGIC!r}, check word)")
    index = copies[0]
    if len(copies) == 2 and 0 < (copies[1][2] - copies[0][2]) & 0xFFFF < 0x8000:
        index = copies[1]
    generation, next_serial, _, slots = index

    def trailer(p):
        check, gen, serial, sequence, used = struct.unpack_from("<5H", page(image, p), DATA_BYTES)
        if check != (TRAILER_SEED + gen + serial + sequence + used) & 0xFFFF or gen != generation or used > DATA_BYTES:
            return None
        return serial, sequence, used

    def first_page(serial):
        if serial not in slots or not FIRST_DATA_PAGE <= slots[serial][0] < pages:
            return None
        t = trailer(slots[serial][0])
        return slots[serial][0] if t is not None and t[:2] == (serial, 0) else None

    def data(serial, start):
        out = bytearray()
        for k in range(ring):
            p = FIRST_DATA_PAGE + (start - FIRST_DATA_PAGE + k) % ring
            t = trailer(p)
            if t is None or t[:2] != (serial, k):
                break
            out += page(image, p)[:t[2]]
        return bytes(out)

    held = []
    for back in range(1, SLOTS + 1):
        serial = (next_serial - back) & 0xFFFF
        start = first_page(serial)
        if start is not None:
            held.append((serial, start))
        elif held:
            break
    held.reverse()
    return [(i + 1, start, slots[serial][1], data(serial, start)) for i, (serial, start) in enumerate(held)]


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
            print(f"{log_id} start_page {start} pages {max(1, (len(data) + DATA_BYTES - 1) // DATA_BYTES)} bytes {len(data)} time_utc {time_utc}")
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
