#!/usr/bin/env python3
"""Checks a screenshot by counting pixels near given colours (no dependencies beyond Python).

    check_screenshot.py FILE [--region X0,Y0,X1,Y1] [--at-least R,G,B:TOL:N]... [--at-most R,G,B:TOL:N]...
    check_screenshot.py --differ FILE_A FILE_B MIN_FRACTION
    check_screenshot.py --same-coverage FILE_A FILE_B MAX_FRACTION
    check_screenshot.py --halves-differ FILE MIN_FRACTION

A pixel counts for R,G,B when each channel is within TOL of it; after --region, only pixels
with X0 <= x < X1 and Y0 <= y < Y1 count, for the checks that follow it. Exits 1, saying which check
failed, when a count is out of bounds or two images differ in fewer than MIN_FRACTION of
their pixels. --same-coverage compares where two images are not black (any channel above
24): it fails when they disagree on more than MAX_FRACTION of the pixels (edges, and the
resampling of a smaller image, disagree a little). --halves-differ compares each pixel of the
left half with the pixel half a width to its right.
"""
import struct
import sys
import zlib


def read_png(path):
    """Decodes an 8-bit RGB or RGBA, non-interlaced PNG into (width, height, rows of RGB)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit(f"{path}: not a PNG")
    pos, idat, header = 8, [], None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        pos += 12 + length
    width, height, depth, color, _, _, interlace = header
    if depth != 8 or color not in (2, 6) or interlace:
        sys.exit(f"{path}: only 8-bit RGB(A) non-interlaced PNGs are read")
    bpp = 3 if color == 2 else 4
    raw = zlib.decompress(b"".join(idat))
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        filt = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1 : (y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if filt == 1:
                line[i] = (line[i] + a) & 255
            elif filt == 2:
                line[i] = (line[i] + b) & 255
            elif filt == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif filt == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append(bytes(line) if bpp == 3 else bytes(v for i, v in enumerate(line) if i % 4 != 3))
        prev = line
    return width, height, rows


def count_near(rows, rgb, tol, region=None):
    r0, g0, b0 = rgb
    n = 0
    x0, y0, x1, y1 = region or (0, 0, len(rows[0]) // 3, len(rows))
    for row in rows[y0:y1]:
        for i in range(3 * x0, min(3 * x1, len(row)), 3):
            if abs(row[i] - r0) <= tol and abs(row[i + 1] - g0) <= tol and abs(row[i + 2] - b0) <= tol:
                n += 1
    return n


def main(args):
    if args[0] == "--differ":
        _, a, b, fraction = args
        wa, ha, ra = read_png(a)
        wb, hb, rb = read_png(b)
        if (wa, ha) != (wb, hb):
            print(f"OK: {a} and {b} differ in size")
            return 0
        differ = sum(
            1
            for x, y in zip(ra, rb)
            for i in range(0, len(x), 3)
            if x[i : i + 3] != y[i : i + 3]
        )
        share = differ / (wa * ha)
        if share < float(fraction):
            print(f"FAIL: {a} and {b} differ in {share:.4%} of pixels, want >= {float(fraction):.4%}")
            return 1
        print(f"OK: {a} and {b} differ in {share:.2%} of pixels")
        return 0
    if args[0] == "--halves-differ":
        _, path, fraction = args
        w, h, rows = read_png(path)
        half = w // 2
        differ = sum(
            1
            for row in rows
            for x in range(half)
            if row[3 * x : 3 * x + 3] != row[3 * (x + half) : 3 * (x + half) + 3]
        )
        share = differ / (half * h)
        ok = share >= float(fraction)
        print(f"{'OK' if ok else 'FAIL'}: {path}: halves differ in {share:.2%} of pixels, want >= {float(fraction):.2%}")
        return 0 if ok else 1
    if args[0] == "--same-coverage":
        _, a, b, fraction = args
        wa, ha, ra = read_png(a)
        wb, hb, rb = read_png(b)
        if (wa, ha) != (wb, hb):
            print(f"FAIL: {a} and {b} differ in size")
            return 1
        covered = lambda row, i: max(row[i], row[i + 1], row[i + 2]) > 24
        disagree = sum(
            1
            for x, y in zip(ra, rb)
            for i in range(0, len(x), 3)
            if covered(x, i) != covered(y, i)
        )
        share = disagree / (wa * ha)
        ok = share <= float(fraction)
        print(f"{'OK' if ok else 'FAIL'}: {a} and {b} disagree on coverage in {share:.2%} of pixels, want <= {float(fraction):.2%}")
        return 0 if ok else 1
    path, checks = args[0], args[1:]
    _, _, rows = read_png(path)
    failed, region = 0, None
    for flag, spec in zip(checks[::2], checks[1::2]):
        if flag == "--region":
            region = tuple(int(v) for v in spec.split(","))
            continue
        color, tol, bound = spec.split(":")
        rgb = tuple(int(v) for v in color.split(","))
        n = count_near(rows, rgb, int(tol), region)
        ok = n >= int(bound) if flag == "--at-least" else n <= int(bound)
        where = f" in {region}" if region else ""
        print(f"{'OK' if ok else 'FAIL'}: {path}: {n} pixels near {rgb} (±{tol}){where}, {flag[2:]} {bound}")
        failed += not ok
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
