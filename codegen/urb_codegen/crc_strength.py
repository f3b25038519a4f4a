"""Measure the error-detection strength of a CRC: which low-weight bit errors it misses.

A CRC misses an error pattern exactly when the XOR of the syndromes of its flipped bits is zero,
where the syndrome of bit i of an n-bit codeword is x^i mod g(x). Counting zero-XOR sets of size
1, 2 and 3 tells whether the Hamming distance is at least 4 for a given length.
"""

from __future__ import annotations

from collections import defaultdict


def _syndromes(width: int, poly: int, codeword_bits: int) -> list[int]:
    mask = (1 << width) - 1
    top = 1 << (width - 1)
    out = []
    reg = 1
    for _ in range(codeword_bits):
        out.append(reg)
        reg = ((reg << 1) & mask) ^ poly if reg & top else (reg << 1) & mask
    return out


def undetected(width: int, poly: int, covered_bytes: int) -> tuple[int, int]:
    """Number of undetected 2-bit and 3-bit error patterns in a frame of `covered_bytes` + check."""
    s = _syndromes(width, poly, covered_bytes * 8 + width)
    positions: dict[int, list[int]] = defaultdict(list)
    for i, v in enumerate(s):
        positions[v].append(i)
    two = sum(len(p) * (len(p) - 1) // 2 for p in positions.values())
    three = 0
    n = len(s)
    for i in range(n):
        for j in range(i + 1, n):
            three += sum(1 for k in positions.get(s[i] ^ s[j], ()) if k > j)
    return two, three


# lobster-trace: urb.CRC_001
def hamming_distance_at_least_4(width: int, poly: int, covered_bytes: int) -> bool:
    """True when every error of 1, 2 or 3 bits in such a frame is detected (1-bit always is)."""
    return undetected(width, poly, covered_bytes) == (0, 0)


def longest_hd4(width: int, poly: int, limit_bytes: int) -> int:
    """Largest covered length (bytes, up to `limit_bytes`) with Hamming distance at least 4."""
    best = 0
    for n in range(1, limit_bytes + 1):
        if not hamming_distance_at_least_4(width, poly, n):
            break
        best = n
    return best
