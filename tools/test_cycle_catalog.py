#!/usr/bin/env python3
"""ctest `tools_cycle_catalog`: the validation studies' selection rules (tools/cycle_catalog.py,
validate_stall.choose_cycles) on databases written here, in the development set's layout but
with other campaigns, angles and frequencies than it has -- the rules must hold on cycles the
studies were not written for; and validate_stall's table per reduced frequency on made results.
Standard library only."""
import csv
import math
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cycle_catalog as cc  # noqa: E402
import validate_stall  # noqa: E402

STALL_DEG = 12.0


def polar_cl(a_deg):
    """A made-up lift polar: linear to 12 deg, then falling."""
    return 0.1 * a_deg if a_deg <= STALL_DEG else 0.1 * STALL_DEG - 0.05 * (a_deg - STALL_DEG)


DOWNSTROKE_DROP = 0.3  # the downstroke's lift below the polar's: hysteresis the polar must not see


def write_database(root, cycles, peer_ids=(), airspeed_mps=30.0):
    """cycles: (id, campaign, mean_deg, amplitude_deg, k) each; 128 samples of
    alpha = mean + amp sin(phase), Cn and Ct such that CL = polar_cl(alpha) on the upstroke and
    DOWNSTROKE_DROP less on the downstroke."""
    os.makedirs(os.path.join(root, "cycles"))
    with open(os.path.join(root, "catalog.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["id", "campaign", "mean_deg", "amplitude_deg", "frequency_hz", "reduced_frequency",
                    "airspeed_mps"])
        for cid, camp, mean, amp, k in cycles:
            w.writerow([cid, camp, mean, amp, k * airspeed_mps / (math.pi * 0.4), k, airspeed_mps])
            with open(os.path.join(root, "cycles", f"{cid}_coeffs.dat"), "w") as g:
                g.write("% Time() Angle(deg) Cn Ct Cm\n")
                for i in range(128):
                    ph = 2 * math.pi * i / 128
                    a = mean + amp * math.sin(ph)
                    cl = polar_cl(a) - (DOWNSTROKE_DROP if math.cos(ph) < 0 else 0.0)
                    ar = math.radians(a)
                    g.write(f"{ph:.2f}\t{a:.6f}\t{cl * math.cos(ar):.6f}\t{cl * math.sin(ar):.6f}\t0\n")
    if peer_ids:
        with open(os.path.join(root, "bl-reference.csv"), "w") as f:
            f.write("id,bl_rms_CL,bl_rms_Cm\n" + "".join(f"{i},0.1,0.01\n" for i in peer_ids))


def database(quasi_static=True):
    """Campaign 7: quasi-static cycles (k = 0.01, means 4, 10, 16 deg, amplitude 9: -5 to 25
    deg) and sweeps at means 2, 7, 12, 16 and 30 deg (amplitude 6), k = 0.02 ... 0.2; campaign
    8: means 7 and 12 at two frequencies."""
    cycles, n = [], 0
    if quasi_static:
        for mean in (4, 10, 16):
            n += 1
            cycles.append((f"q{n}", "7", mean, 9, 0.01))
    for mean in (2, 7, 12, 16, 30):
        for k in (0.02, 0.05, 0.1, 0.15, 0.2):
            n += 1
            cycles.append((f"s{n}", "7", mean, 6, k))
    for mean in (7, 12):
        for k in (0.05, 0.1):
            n += 1
            cycles.append((f"t{n}", "8", mean, 5, k))
    return cycles


class CycleCatalogTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.root = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def selections(self):
        catalog = cc.read_catalog(self.root)
        cycles, source = cc.polar_cycles(catalog)
        bins = cc.upstroke_bins(self.root, cycles)
        lo, hi = min(bins), max(bins)
        stall = cc.stall_angle_deg(bins)
        sweep, group = cc.choose_sweep(self.root, catalog, stall, lo, hi)
        means = cc.choose_means(self.root, catalog, group, [c["k"] for c in sweep], lo, hi)
        return source, stall, sweep, group, means, (lo, hi)

    def test_rules_on_a_database_with_quasi_static_cycles(self):
        write_database(self.root, database())
        source, stall, sweep, group, means, (lo, hi) = self.selections()
        self.assertIn("3 quasi-static cycles", source)
        # The polar is the upstrokes': the downstroke's hysteresis is not in it.
        bins = cc.upstroke_bins(self.root, cc.polar_cycles(cc.read_catalog(self.root))[0])
        for a in (0.0, 8.0, 20.0):
            self.assertAlmostEqual(bins[a][4] / bins[a][0], polar_cl(a), delta=0.03)
        self.assertEqual(stall, STALL_DEG)
        self.assertEqual((lo, hi), (-5.0, 25.0))
        # The sweep: mean nearest the stall angle, three frequencies spread over 0.02-0.2.
        self.assertEqual(group, ("7", 12.0, 6.0))
        self.assertEqual([c["k"] for c in sweep], [0.05, 0.1, 0.15])
        # Means at the sweep's middle frequency: the ends and the one nearest their middle;
        # mean 30 (24-36 deg) leaves the polar and is never chosen.
        self.assertEqual([c["mean"] for c in means], [2.0, 7.0, 16.0])
        self.assertTrue(all(c["k"] == 0.1 and c["campaign"] == "7" for c in means))
        self.assertEqual(cc.regime(11.9, stall), "attached")
        self.assertEqual(cc.regime(12.0, stall), "light")
        self.assertEqual(cc.regime(18.9, stall), "light")
        self.assertEqual(cc.regime(19.0, stall), "deep")

    def test_without_quasi_static_cycles_the_polar_says_what_it_is_and_its_cycles_stay_out(self):
        write_database(self.root, database(quasi_static=False) + [("b1", "7", 12, 6, 0.015), ("b2", "7", 12, 6, 0.023)])
        catalog = cc.read_catalog(self.root)
        self.assertTrue(cc.is_quasi_static(next(c for c in catalog if c["id"] == "b1")))
        catalog = [c for c in catalog if c["id"] != "b1"]
        cycles, source = cc.polar_cycles(catalog)
        self.assertIn("NO quasi-static cycle", source)
        # The slowest cycles: k within 10 % of the lowest (0.02), not 0.023.
        self.assertEqual(sorted({c["k"] for c in cycles}), [0.02])
        ids = {c["id"] for c in cycles}
        bins = cc.upstroke_bins(self.root, cycles)
        sweep, group = cc.choose_sweep(self.root, catalog, STALL_DEG, min(bins), max(bins), ids)
        means = cc.choose_means(self.root, catalog, group, [c["k"] for c in sweep], min(bins), max(bins), ids)
        self.assertFalse(ids & {c["id"] for c in sweep + means})
        # Below k = 0.05 only the polar's cycles would make a sweep (0.02, 0.023, 0.05 at mean 12).
        slow = [c for c in catalog if c["k"] <= 0.05]
        with self.assertRaises(SystemExit):
            cc.choose_sweep(self.root, slow, STALL_DEG, min(bins), max(bins), ids)
        self.assertTrue(cc.choose_sweep(self.root, slow, STALL_DEG, min(bins), max(bins)))
        fit, held, _ = validate_stall.choose_cycles(self.root, catalog)
        self.assertFalse(ids & {c["id"] for c in fit + held})

    def test_no_sweep_is_an_error_not_a_guess(self):
        write_database(self.root, [("q1", "7", 10, 9, 0.01), ("a", "7", 10, 5, 0.05), ("b", "7", 10, 5, 0.1)])
        with self.assertRaises(SystemExit) as e:
            self.selections()
        self.assertIn("no frequency sweep", str(e.exception))

    def test_bad_catalog_row_names_the_line(self):
        write_database(self.root, database())
        with open(os.path.join(self.root, "catalog.csv"), "a") as f:
            f.write("x9,7,abc,6,1.0,0.1,30\n")
        with self.assertRaises(SystemExit) as e:
            cc.read_catalog(self.root)
        self.assertIn("catalog.csv:34:", str(e.exception))

    def test_repeated_ids_nonpositive_k_and_missing_files_are_refused(self):
        write_database(self.root, database())
        path = os.path.join(self.root, "catalog.csv")
        with open(path) as f:
            good = f.read()
        for extra, message in (("s4,7,2,6,1.0,0.1,30\n", "repeats line"),
                               ("x9,7,2,6,1.0,-0.1,30\n", "must be finite and > 0"),
                               ("x9,7,2,6,1.0,nan,30\n", "must be finite and > 0"),
                               ("x9,7,2,6,1.0,0.1,30\n", "cycle file not found")):
            with open(path, "w") as f:
                f.write(good + extra)
            with self.assertRaises(SystemExit) as e:
                cc.read_catalog(self.root)
            self.assertIn(message, str(e.exception))
            self.assertIn("catalog.csv:34:", str(e.exception))

    def test_one_frequency_at_two_airspeeds_is_one_frequency(self):
        # Mean 12 at k = 0.05 and 0.1 at 30 m/s, and 0.1007 at 60 m/s: two frequencies, no sweep
        # at mean 12; the sweep is then mean 7's (three frequencies).
        cycles = [("q1", "7", 10, 15, 0.01), ("a", "7", 12, 5, 0.05), ("b", "7", 12, 5, 0.1),
                  ("c", "7", 12, 5, 0.1007), ("d", "7", 7, 5, 0.05), ("e", "7", 7, 5, 0.1), ("f", "7", 7, 5, 0.15)]
        write_database(self.root, cycles)
        catalog = cc.read_catalog(self.root)
        sweep, group = cc.choose_sweep(self.root, catalog, STALL_DEG, -5.0, 25.0)
        self.assertEqual(group, ("7", 7.0, 5.0))

    def test_stall_study_holds_out_the_peers_cycles_and_fits_other_campaigns(self):
        cycles = database()
        peer = [c[0] for c in cycles if c[1] == "8"]
        write_database(self.root, cycles, peer_ids=peer)
        fit, held, bl = validate_stall.choose_cycles(self.root, cc.read_catalog(self.root))
        self.assertEqual(sorted(c["id"] for c in held), sorted(peer))
        self.assertTrue(fit and all(c["campaign"] == "7" and c["k"] > cc.QUASI_STATIC_K for c in fit))
        self.assertEqual(set(bl), set(peer))

    def test_stall_study_without_a_peer_holds_out_a_campaign(self):
        write_database(self.root, database())
        fit, held, bl = validate_stall.choose_cycles(self.root, cc.read_catalog(self.root))
        self.assertEqual(bl, {})
        self.assertEqual({c["campaign"] for c in held}, {"7"})
        self.assertEqual({c["campaign"] for c in fit}, {"8"})


class StallReportTest(unittest.TestCase):
    def test_k_table_groups_cycles_by_k_to_0025_and_leaves_a_failed_prediction_out(self):
        def cycle(k, diag_cl):
            r = {"k": k, "regime": "light"}
            for coef, scale in (("CL", 1.0), ("Cm", 0.1)):
                r.update({f"qs_{coef}": 0.4 * scale, f"report_{coef}": 0.3 * scale,
                          f"extended_{coef}": 0.2 * scale, f"bl_{coef}": 0.25 * scale})
            r["diagnosed_CL"], r["diagnosed_Cm"] = diag_cl, 0.01
            return r
        import contextlib
        import io
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            validate_stall.k_table([cycle(0.0247, 0.1), cycle(0.0262, float("nan")), cycle(0.0511, 0.2)])
        rows = [l.split("|")[1:-1] for l in out.getvalue().splitlines() if l.startswith("| 0.")]
        cells = {(r[0].strip(), r[2].strip()): [c.strip() for c in r] for r in rows}
        self.assertEqual(sorted(cells), [("0.025", "CL"), ("0.025", "Cm"), ("0.050", "CL"), ("0.050", "Cm")])
        self.assertEqual(cells[("0.025", "CL")][1], "2")  # 0.0247 and 0.0262 are both k = 0.025
        self.assertEqual(cells[("0.025", "CL")][6], "0.1000")  # the NaN (a failed prediction) left out
        self.assertEqual(cells[("0.025", "CL")][8:], ["0.80", "0.40"])  # extended / BL, diagnosed / BL
        self.assertEqual(cells[("0.050", "CL")][8:], ["0.80", "0.80"])
        self.assertEqual(cells[("0.050", "Cm")][9], "0.40")


if __name__ == "__main__":
    unittest.main()
