#!/usr/bin/env python3
"""ctest `tools_moment_breaks`: tools/moment_breaks.py finds the breaks it is meant to find on
cycles made here (dips of known phase, depth and width), and measures their gap in semichords.
Standard library only."""
import math
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import moment_breaks as mb  # noqa: E402

N = 128


def cycle(dips, mean_deg=20.0, amp_deg=10.0, n=N):
    """Rows as cycle_catalog.read_cycle gives them: (phase, alpha, Cn, Ct, Cm, CL). dips: (phase
    of the dip's centre in rad, depth, width in rad) each, on a C_m of -0.02."""
    rows = []
    for i in range(n):
        ph = 2.0 * math.pi * i / n
        cm = -0.02 - sum(d * math.exp(-0.5 * ((ph - c) / w) ** 2) for c, d, w in dips)
        rows.append((ph, mean_deg + amp_deg * math.sin(ph), 1.0, 0.0, cm, 1.0))
    return rows


class MomentBreaks(unittest.TestCase):
    def test_two_breaks_and_their_gap_in_semichords(self):
        k = 0.1
        first, second = 1.40, 2.20  # the second on the downstroke (past pi / 2)
        breaks, gap = mb.cycle_breaks(cycle([(first, 0.5, 0.08), (second, 0.25, 0.08)]), k)
        self.assertEqual(len(breaks), 2)
        self.assertLess(breaks[0][2], breaks[1][2])  # deepest first
        self.assertAlmostEqual(breaks[0][0], first, delta=2 * math.pi / N)
        self.assertAlmostEqual(breaks[1][0], second, delta=2 * math.pi / N)
        self.assertTrue(breaks[0][3])                # rising at the first, falling at the second
        self.assertFalse(breaks[1][3])
        self.assertAlmostEqual(gap, (second - first) / k, delta=2 * math.pi / N / k)

    def test_one_break_has_no_gap(self):
        breaks, gap = mb.cycle_breaks(cycle([(1.5, 0.5, 0.1)]), 0.05)
        self.assertEqual(len(breaks), 1)
        self.assertIsNone(gap)

    def test_a_dip_shallower_than_min_depth_is_not_a_break(self):
        breaks, _ = mb.cycle_breaks(cycle([(1.5, 0.5, 0.1), (2.5, 0.5 * mb.MIN_DEPTH, 0.1)]), 0.05)
        self.assertEqual(len(breaks), 1)

    def test_a_cycle_of_other_sample_count_gives_the_same_breaks(self):
        dips = [(1.40, 0.5, 0.08), (2.20, 0.25, 0.08)]
        for n in (64, 256):
            breaks, gap = mb.cycle_breaks(cycle(dips, n=n), 0.1)
            self.assertEqual(len(breaks), 2, n)
            self.assertAlmostEqual(gap, 8.0, delta=2 * math.pi / n / 0.1)

    def test_a_break_across_the_cycle_end_is_found_once(self):
        breaks, _ = mb.cycle_breaks(cycle([(0.0, 0.4, 0.1), (2 * math.pi, 0.4, 0.1)]), 0.05)
        self.assertEqual(len(breaks), 1)


if __name__ == "__main__":
    unittest.main()
