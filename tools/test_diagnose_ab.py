#!/usr/bin/env python3
"""ctest `tools_diagnose_ab`: tools/diagnose_ab.py's summary (docs/diagnose-speed.md) counts the
same final models, each build's wall times and the per-case ratio from its case lines, and the
held-out comparison of the changed models (docs/periodic-stall.md), as written here. Standard library only."""
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import diagnose_ab as ab  # noqa: E402


def line(old_eff, old_err, old_s, new_eff, new_err, new_s):
    return (f"sweep ('5', 6.0, 8.0)        CL bl     old {old_eff} {old_err:.5f} {old_s:5.1f}s | "
            f"new {new_eff} {new_err:.5f} {new_s:5.1f}s")


class Summary(unittest.TestCase):
    def test_counts_models_times_and_ratios(self):
        lines = ['3 training triples',
                 line([], 0.01, 20.0, [], 0.01, 5.0),
                 line(['bias'], 0.02, 8.0, ['bias'], 0.02, 8.0),
                 line(['bias'], 0.03, 12.0, ['b1_alpha'], 0.03, 3.0) + ' || held-out median/QS old 0.9 (1) new 0.8 (2)']
        s = ab.summarize(lines)
        self.assertEqual(s[0], '3 cases; the final model the same (effects, fit error to 5 decimals) in 2')
        self.assertIn('old: wall time median 12.0 s (quartiles 10.0-16.0), largest 20.0 s, total 40 s; 1 of 3 within 10 s', s[1])
        self.assertIn('new: wall time median 5.0 s (quartiles 4.0-6.5), largest 8.0 s, total 16 s; 3 of 3 within 10 s', s[2])
        self.assertIn('new / old per case: median 0.25 (quartiles 0.25-0.62, range 0.25-1.00)', s[3])
        # The one changed model's held-out line: CL and bl groups too, no Cm or report group.
        self.assertEqual(s[4], 'held-out, all: 1 changed models, 1 better, 0 worse (median ratio); '
                               'cycles at <= 0.5x 1 -> 2; median of the medians 0.900 -> 0.800')
        self.assertEqual([x.split(':')[0] for x in s[4:]], ['held-out, all', 'held-out, CL', 'held-out, bl'])

    def test_heldout_summary_counts_better_worse_and_ties(self):
        held = ' || held-out median/QS old {} ({}) new {} ({}); mean old 1.0 new 1.0'
        lines = [line([], 0.01, 1.0, ['bias'], 0.02, 1.0) + held.format(0.9, 3, 0.5, 7),
                 line([], 0.01, 1.0, ['bias'], 0.02, 1.0).replace(' CL bl    ', ' Cm report') + held.format(0.5, 4, 0.7, 1),
                 line([], 0.01, 1.0, ['bias'], 0.02, 1.0) + held.format(0.6, 2, 0.603, 2)]
        h = ab.heldout_summary(lines)
        self.assertEqual(h[0], 'held-out, all: 3 changed models, 1 better, 1 worse (median ratio); '
                               'cycles at <= 0.5x 9 -> 10; median of the medians 0.600 -> 0.603')
        self.assertTrue(h[2].startswith('held-out, Cm: 1 changed models, 0 better, 1 worse'))

    def test_a_changed_fit_error_is_a_changed_model(self):
        s = ab.summarize([line([], 0.01, 1.0, [], 0.01001, 1.0)])
        self.assertTrue(s[0].endswith('in 0'))

    def test_no_case_lines(self):
        self.assertEqual(ab.summarize(['16 training triples']), ['no case lines'])


if __name__ == '__main__':
    unittest.main()
