#!/usr/bin/env python3
"""ctest `tools_qs_floor`: tools/qs_floor.py's floor |mean e| / rms e on cycles made with a
known offset and a known variation about it, over a static polar built from quasi-static cycles
of a known line, and its per-regime counts. Standard library only."""
import math
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cycle_catalog  # noqa: E402
import qs_floor  # noqa: E402
import validate_real as vr  # noqa: E402

SLOPE_PER_DEG = 0.1  # the static Cn line; Ct = 0, Cm = -0.01 Cn


def write_cycle(path, mean_deg, amp_deg, offset, wiggle):
    """128 samples of alpha = mean + amp sin(phase); Cn = static + offset + wiggle sin(2 phase)."""
    with open(path, 'w') as f:
        f.write('% Time() Angle(deg) Cn Ct Cm\n')
        for i in range(128):
            ph = 2 * math.pi * i / 128
            a = mean_deg + amp_deg * math.sin(ph)
            cn = SLOPE_PER_DEG * a + offset + wiggle * math.sin(2 * ph)
            f.write(f'{ph:.6f} {a:.9f} {cn:.12f} 0 {-0.01 * cn:.12f}\n')


class QsFloor(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        d = self.tmp.name
        os.makedirs(os.path.join(d, 'cycles'))
        rows = ['id,campaign,mean_deg,amplitude_deg,frequency_hz,reduced_frequency,airspeed_mps']
        # Quasi-static cycles spanning -17..23 deg, the test cycles (-1..9) inside both (the polar: Cn on a line, so CL = Cn cos a).
        for i, mean in enumerate((-2.0, 8.0)):
            write_cycle(os.path.join(d, 'cycles', f'q{i}_coeffs.dat'), mean, 15.0, 0.0, 0.0)
            rows.append(f"q{i},1,{mean},15,0.1,0.010,40")
        # offset 0.06 and a wiggle of amplitude 0.06: rms = sqrt(0.06^2 + 0.06^2 / 2), floor 0.816.
        write_cycle(os.path.join(d, 'cycles', 'big_coeffs.dat'), 4.0, 5.0, 0.06, 0.06)
        rows.append('big,1,4,5,1,0.1,40')
        # offset 0.01, wiggle 0.1: floor 0.14.
        write_cycle(os.path.join(d, 'cycles', 'small_coeffs.dat'), 4.0, 5.0, 0.01, 0.1)
        rows.append('small,1,4,5,1,0.1,40')
        with open(os.path.join(d, 'catalog.csv'), 'w') as f:
            f.write('\n'.join(rows) + '\n')
        self.data = d
        vr.DATA = d
        self.catalog = cycle_catalog.read_catalog(d)
        info = vr.static_table(self.catalog, os.path.join(d, 'static.dat'))
        self.info = info
        self.table = qs_floor.read_table(os.path.join(d, 'static.dat'))

    def tearDown(self):
        self.tmp.cleanup()

    def test_static_value_interpolates_and_holds_the_ends(self):
        t = [(0.0, {'CL': 0.0}), (2.0, {'CL': 1.0})]
        self.assertAlmostEqual(qs_floor.static_value(t, 'CL', 0.5), 0.25)
        self.assertEqual(qs_floor.static_value(t, 'CL', -3.0), 0.0)
        self.assertEqual(qs_floor.static_value(t, 'CL', 9.0), 1.0)

    def test_the_floor_is_the_offset_over_the_rms(self):
        by_id = {c['id']: c for c in self.catalog}
        self.assertEqual(self.info[5], {'q0', 'q1'})
        for cid, offset, wiggle in (('big', 0.06, 0.06), ('small', 0.01, 0.1)):
            e = qs_floor.cycle_errors(self.data, by_id[cid], self.table)
            rms, mean = e['CL']
            # CL = Cn cos a over the polar's CL = Cn cos a at the bins (linear between 1-deg rows):
            # the table's own error (1-deg bins of about two upstroke samples each) is below 2.5e-3 here.
            self.assertAlmostEqual(mean, offset * sum(math.cos(math.radians(4 + 5 * math.sin(2 * math.pi * i / 128)))
                                                      for i in range(128)) / 128, delta=2.5e-3)
            want = offset / math.sqrt(offset ** 2 + wiggle ** 2 / 2)
            self.assertAlmostEqual(qs_floor.floor_ratio(rms, mean), want, delta=0.03)
            rms_m, mean_m = e['Cm']
            self.assertAlmostEqual(qs_floor.floor_ratio(rms_m, mean_m), want, delta=0.03)

    def test_the_regime_table_counts_cycles_under_half(self):
        cycles = [c for c in self.catalog if c['id'] not in self.info[5]]
        errors = {c['id']: qs_floor.cycle_errors(self.data, c, self.table) for c in cycles}
        lines = qs_floor.regime_table(cycles, errors, lambda c: 'attached')
        row = next(r for r in lines if r.startswith('| attached |'))
        self.assertIn('| 1 of 2 |', row)  # 'small' only, for CL and for Cm
        self.assertEqual(row.count('1 of 2'), 2)


if __name__ == '__main__':
    unittest.main()
