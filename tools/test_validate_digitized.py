#!/usr/bin/env python3
"""ctest `tools_validate_digitized`: tools/validate_digitized.py's digitizer on a known cycle:
phases strictly increasing in [0, 2 pi) and near an even spacing, readings on the cycle's
periodic linear interpolation within the stated reading error, reproducible by seed, and the
digitized files written in the layout the experiment's [columns] read. Standard library only."""
import math
import os
import statistics
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import validate_digitized as vd  # noqa: E402


def cycle(n=128):
    """A smooth periodic cycle with a sharp feature: sin + 0.3 sin(3 phase), peak-to-peak ~2."""
    return [math.sin(2 * math.pi * i / n) + 0.3 * math.sin(6 * math.pi * i / n) for i in range(n)]


class Digitizer(unittest.TestCase):
    def test_periodic_linear_is_exact_at_samples_and_wraps(self):
        v = cycle()
        for i in (0, 5, 127):
            self.assertAlmostEqual(vd.periodic_linear(v, 2 * math.pi * i / 128), v[i], places=12)
        # Between the last sample and the first, the interpolation wraps.
        mid = vd.periodic_linear(v, 2 * math.pi * 127.5 / 128)
        self.assertAlmostEqual(mid, 0.5 * (v[127] + v[0]), places=12)

    def test_phases_increase_inside_one_cycle_near_an_even_spacing(self):
        for n in vd.N_POINTS:
            ph, _ = vd.digitize(cycle(), n, f"c-{n}")
            self.assertEqual(len(ph), n)
            self.assertTrue(all(b > a for a, b in zip(ph, ph[1:])))
            self.assertGreaterEqual(ph[0], 0.0)
            self.assertLess(ph[-1], 2 * math.pi)
            step = 2 * math.pi / n
            for k, p in enumerate(ph):
                self.assertLessEqual(abs(p - k * step), vd.JITTER * step + 1e-12)
            # Not the even grid itself: the jitter moves them.
            self.assertGreater(max(abs(p - k * step) for k, p in enumerate(ph)), 0.1 * step)

    def test_readings_carry_the_stated_error_and_no_bias(self):
        v = cycle()
        spread = max(v) - min(v)
        n = 4000
        ph, r = vd.digitize(v, n, "many")
        err = [a - vd.periodic_linear(v, p) for p, a in zip(ph, r)]
        sd = statistics.pstdev(err)
        self.assertAlmostEqual(sd / (vd.READ_ERROR * spread), 1.0, delta=0.06)
        self.assertLess(abs(statistics.fmean(err)), 4 * sd / math.sqrt(n))

    def test_same_seed_same_digitization_other_seed_other(self):
        a = vd.digitize(cycle(), 40, "x")
        self.assertEqual(a, vd.digitize(cycle(), 40, "x"))
        self.assertNotEqual(a[0], vd.digitize(cycle(), 40, "y")[0])

    def test_written_file_has_the_database_layout(self):
        ph, r = vd.digitize(cycle(), 40, "w")
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "q.dat")
            vd.write_quantity(path, "Cm", ph, r)
            with open(path) as f:
                lines = f.read().splitlines()
        self.assertEqual(lines[0], "% Time() Cm")
        self.assertEqual(len(lines), 41)
        back = [tuple(float(x) for x in line.split()) for line in lines[1:]]
        for (p, v), (p0, v0) in zip(back, zip(ph, r)):
            self.assertAlmostEqual(p, p0, places=8)
            self.assertAlmostEqual(v, v0, delta=1e-8 * max(1.0, abs(v0)))


if __name__ == "__main__":
    unittest.main()
