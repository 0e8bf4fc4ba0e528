#!/usr/bin/env python3
"""ctest `tools_compare_forcing_lag`: tools/compare_forcing_lag.py's variants are the extended
model of tools/validate_stall.py with only their own [model] keys changed (tomllib), each key
once, and its report prints a column per variant. Standard library only."""
import contextlib
import io
import os
import sys
import tempfile
import tomllib
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compare_forcing_lag as cfl  # noqa: E402


class CompareForcingLag(unittest.TestCase):
    def test_each_variant_changes_only_its_keys(self):
        runs = [{'file': 'fit_1.csv', 'f': 1.2, 'v': 40.0}, {'file': 'fit_2.csv', 'f': 2.4, 'v': 40.0}]
        with tempfile.TemporaryDirectory() as tmp:
            models = {}
            for coef in ('CL', 'Cm'):
                for form in cfl.FORMS:
                    path = os.path.join(tmp, f'{coef}-{form}.toml')
                    cfl.variant_experiment(path, coef, form, runs, 40.0, (12.0, 16.0))
                    with open(path, 'rb') as f:
                        models[(coef, form)] = tomllib.load(f)['model']  # a repeated key would raise
            for coef in ('CL', 'Cm'):
                base = models[(coef, 'delay')]
                self.assertEqual(base['stall'], 'separation_and_vortex')
                for form in cfl.FORMS:
                    m = dict(models[(coef, form)])
                    expected = tomllib.loads(cfl.VARIANTS[form])
                    for key, value in expected.items():
                        self.assertEqual(m.pop(key), value, (coef, form, key))
                    rest = {k: v for k, v in base.items() if k not in expected}
                    self.assertEqual(m, rest, (coef, form))
            self.assertEqual(models[('Cm', 'first_order_f0c1')]['stall_f0_correction_degree'], 1)

    def test_the_report_has_a_column_per_variant(self):
        row = {'id': '1', 'mean': 8.0, 'k': 0.1, 'regime': 'light'}
        for coef in ('CL', 'Cm'):
            row[f'bl_{coef}'] = 0.2
            for i, form in enumerate(cfl.FORMS):
                row[f'{form}_{coef}'] = 0.1 * (i + 1)
        fj = {'fit_error': 0.1, 'termination': 'converged', 'wall_s': 1.0,
              'parameters': [{'name': 'T1', 'value': 2.0}, {'name': 'f0c_0', 'value': 0.25}]}
        models = {(coef, form): ('m.coef', fj) for coef in ('CL', 'Cm') for form in cfl.FORMS}
        out = io.StringIO()
        describe = cfl.vs.describe
        cfl.vs.describe = lambda cycles: 'cycles'
        try:
            with contextlib.redirect_stdout(out):
                cfl.report([row], 'the polar', 15.0, [], [], models)
        finally:
            cfl.vs.describe = describe
        text = out.getvalue()
        self.assertIn('| light | 1 | Cm | 0.1000 | 0.2000 | 0.3000 | 0.2000 | 0.50 | 1.00 | 1.50 |', text)
        self.assertIn('| Cm | first_order_f0c1 | 0.10000 | converged | 2.000 | nan | nan | 0.250 | nan | 1 |', text)


if __name__ == '__main__':
    unittest.main()
