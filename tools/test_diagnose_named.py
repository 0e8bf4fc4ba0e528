#!/usr/bin/env python3
"""ctest `tools_diagnose_named`: tools/diagnose_named.py's summary counts the diagnoses that
named an effect and, of those, the ones whose final model predicts the other cycles better
than the configured one (by the median and by the mean ratio), from made results. Standard
library only."""
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diagnose_named as dn  # noqa: E402


class Summary(unittest.TestCase):
    def test_counts(self):
        results = [
            ('report', 'CL', [], None, None),                                  # named nothing
            ('report', 'CL', ['vortex_shedding'], [0.8, 0.9, 1.0], [0.4, 0.5, 2.0]),  # median better, mean worse
            ('report', 'Cm', ['bias'], [0.6, 0.6, 0.6], [0.7, 0.7, 0.7]),      # worse both ways
            ('bl', 'Cm', ['a_alpha'], [1.0, 1.0], [0.3, 0.4]),                 # better both ways
        ]
        rows = {tuple(c.strip() for c in r.split('|')[1:3]): r for r in dn.summary(results)[2:]}
        cl = rows[('report', 'CL')]
        self.assertIn('| 2 | 1 | 1 of 1 | 0 of 1 | 0 -> 2 |', cl)
        self.assertIn('| 1 | 1 | 0 of 1 | 0 of 1 | 0 -> 0 |', rows[('report', 'Cm')])
        self.assertIn('| 3 | 2 | 1 of 2 | 0 of 2 | 0 -> 2 |', rows[('report', 'all')])
        self.assertIn('| 1 | 1 | 1 of 1 | 1 of 1 | 0 -> 2 |', rows[('bl', 'Cm')])
        self.assertNotIn(('bl', 'CL'), rows)


if __name__ == '__main__':
    unittest.main()
