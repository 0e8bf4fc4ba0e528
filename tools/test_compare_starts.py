#!/usr/bin/env python3
"""ctest `tools_compare_starts`: tools/compare_starts.py's variants are valid [model] sections
(tomllib) with their placeholders filled, and a hold reads T1, T2 from the C_L fit's
coefficient file it names, refusing one without them. Standard library only."""
import os
import sys
import tempfile
import tomllib
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compare_starts as cs  # noqa: E402


class CompareStarts(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.coef = os.path.join(self.tmp.name, 'model.coef')
        with open(self.coef, 'w') as f:
            f.write('indicial-coef 2\ncoefficient CL\nsep_time_constants 2.5 1.25\nend_coefficient\n')

    def tearDown(self):
        self.tmp.cleanup()

    def test_every_variant_is_a_model_section(self):
        holds = {name: self.coef for name, _, _ in cs.VARIANTS}
        for name, _, template in cs.VARIANTS:
            keys = cs.model_keys(template, [10, 15], '/data/static.dat', holds)
            model = tomllib.loads('[model]\n' + keys)['model']
            self.assertNotIn('{knots}', keys, name)
            self.assertNotIn('{static}', keys, name)
            if 'a_knots_deg' in model:
                self.assertEqual(model['a_knots_deg'], [10, 15])
            if 'stall' in model:
                self.assertEqual(model['stall_polar'], '/data/static.dat')
            if 'HOLD' in template:
                self.assertEqual(model['stall_known'], {'T1': 2.5, 'T2': 1.25}, name)
            else:
                self.assertNotIn('stall_known', model, name)

    def test_a_hold_needs_the_time_constants(self):
        with open(self.coef, 'w') as f:
            f.write('indicial-coef 2\ncoefficient CL\nend_coefficient\n')
        with self.assertRaises(RuntimeError):
            cs.separation_time_constants(self.coef)


if __name__ == '__main__':
    unittest.main()
