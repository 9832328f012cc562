#!/usr/bin/env python3
"""Data files for the CSV / .npy reader figures of benches/results/slicot.md (no numpy needed).

    python3 benches/peers/csv_data.py N OUT.csv [OUT.npy]

Writes N rows of the peer system of ``peers.py`` (2 inputs, 2 outputs, order 4,
random binary inputs +-1, output noise of standard deviation 0.1, seeded) with
columns t,u1,u2,y1,y2: t = k * 0.001 printed with 3 decimals, u as -1/1, y with
14 decimals (about 50 bytes per row). With a third argument the same numbers
(t included) are also written as a C-order float64 .npy file (format 1.0), by
hand: magic, header dict, little-endian data.
"""
import random
import struct
import sys

A = [[0.9, 0.2, 0.0, 0.0], [-0.2, 0.9, 0.0, 0.0], [0.0, 0.0, 0.7, 0.0], [0.0, 0.0, 0.0, -0.5]]
B = [[1.0, 0.0], [0.0, 1.0], [1.0, 0.5], [0.3, 1.0]]
C = [[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]]


def npy_header(rows, cols):
    d = "{'descr': '<f8', 'fortran_order': False, 'shape': (%d, %d), }" % (rows, cols)
    # magic (6) + version (2) + length (2) + dict + padding + '\n', a multiple of 64
    total = 10 + len(d) + 1
    d += " " * ((64 - total % 64) % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(d)) + d.encode("latin1")


def main():
    n = int(float(sys.argv[1]))
    csv_path = sys.argv[2]
    npy_path = sys.argv[3] if len(sys.argv) > 3 else None
    rng = random.Random(20261121)
    x = [0.0, 0.0, 0.0, 0.0]
    out = open(csv_path, "w", buffering=1 << 20)
    npy = open(npy_path, "wb", buffering=1 << 20) if npy_path else None
    out.write("t,u1,u2,y1,y2\n")
    if npy:
        npy.write(npy_header(n, 5))
    pack = struct.Struct("<5d").pack
    lines = []
    for k in range(n):
        u1 = 1.0 if rng.random() < 0.5 else -1.0
        u2 = 1.0 if rng.random() < 0.5 else -1.0
        y1 = x[0] + x[2] + rng.gauss(0.0, 0.1)
        y2 = x[1] + x[3] + rng.gauss(0.0, 0.1)
        x = [
            A[0][0] * x[0] + A[0][1] * x[1] + u1,
            A[1][0] * x[0] + A[1][1] * x[1] + u2,
            0.7 * x[2] + u1 + 0.5 * u2,
            -0.5 * x[3] + 0.3 * u1 + u2,
        ]
        t = "%.3f" % (k * 0.001)
        a, b, c, d = "%d" % u1, "%d" % u2, "%.14f" % y1, "%.14f" % y2
        lines.append("%s,%s,%s,%s,%s\n" % (t, a, b, c, d))
        if npy:
            npy.write(pack(float(t), u1, u2, float(c), float(d)))
        if len(lines) == 65536:
            out.write("".join(lines))
            lines.clear()
    out.write("".join(lines))
    out.close()
    if npy:
        npy.close()


if __name__ == "__main__":
    main()
