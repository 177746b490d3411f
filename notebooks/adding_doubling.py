"""Independent reference for the random walk (src/random_walk): total reflectance and transmittance of
a plane-parallel scattering slab, index 1 on both sides, under collimated incidence, by Scott
Prahl's adding-doubling program iadpython (Prahl 1995, "The adding-doubling method", in Optical-
Thermal Response of Laser-Irradiated Tissue, ch. 5).

The test `random_walk::tests::index_matched_slabs_match_adding_doubling` reads the values from
tests/data/adding_doubling.json. `--write` produces that file; `--check` recomputes it and exits
non-zero when the committed file no longer matches what iadpython computes (scripts/test runs it
through scripts/adding-doubling, which installs the packages), so the data's provenance is checked.

Run: scripts/adding-doubling --write   (or --check), which installs iadpython, numpy and scipy
(iadpython imports scipy without declaring it) into target/adding-doubling-env and runs
     python notebooks/adding_doubling.py --write tests/data/adding_doubling.json

How the values are read:
- Normal incidence: iadpython's own `Sample(a, b, g, n=1, quad_pts=N).rt()`, whose first two results
  are the total reflectance and transmittance (unscattered light included) for collimated light.
- Oblique incidence: `Sample.rt()` is written for normal incidence only (its `rt_matrices` returns an
  empty layer when `nu_0 != 1`: "cone not implemented yet"). The adding-doubling matrices themselves
  hold every incidence direction of the quadrature: `R[i, j]` and `T[i, j]` carry light from
  quadrature direction `j` to direction `i`, and the total reflectance for collimated light along
  direction `j` is `sum_i 2 nu_i w_i R[i, j]`, the sum iadpython's `UX1_and_UXU` takes for the
  normal direction (the last one). Setting `nu_0 = mu` before `update_quadrature()` makes `mu` a
  quadrature direction (Radau points on [0, mu] and on [mu, 1]), exactly as Prahl's C program does
  for oblique incidence; `nu_0` is then put back to 1 so that `rt_matrices` computes the matrices
  on that quadrature. The script checks this reading against two exact facts before using it: with
  no scattering, T = exp(-b / mu) and R = 0; and the normal column equals `rt()` at normal incidence.
- Tolerance: iadpython truncates the phase function by the delta-M method with as many Legendre
  terms as quadrature points, and integrates on that quadrature: each value is computed with two
  quadratures (24 and 16 points at normal incidence; 48 and 32 for oblique, i.e. 24 and 16 on each
  side of mu) and the tolerance is their difference plus 1e-5. More points are no use: iadpython's
  Radau rule loses accuracy past 24 points (its weights sum to 1 within 7e-9 at 24, 4e-5 at 32).
"""
import argparse
import json
import math
import sys

import numpy as np
import scipy
import iadpython as iad

# (albedo a = sigma_s / (sigma_s + sigma_k), optical thickness b = (sigma_s + sigma_k) depth, g).
SLABS = [
    (a, b, g)
    for b in (0.5, 8.0)
    for g in (0.0, 0.9, -0.5)
    for a in (0.5, 0.99)
]
COSINES = (1.0, 0.5)
NORMAL_POINTS = (24, 16)
OBLIQUE_POINTS = (48, 32)
TOLERANCE_FLOOR = 1e-5


def normal_incidence(a, b, g, points):
    sample = iad.Sample(a=a, b=b, g=g, n=1.0, quad_pts=points)
    ur1, ut1, _, _ = sample.rt()
    return float(ur1), float(ut1)


def oblique_incidence(a, b, g, mu, points):
    """Total R and T for collimated light at cosine mu, and at normal incidence, from one quadrature
    that holds both directions."""
    sample = iad.Sample(a=a, b=b, g=g, n=1.0, quad_pts=points)
    sample.nu_0 = mu
    sample.update_quadrature()
    sample.nu_0 = 1.0
    j = int(np.argmin(np.abs(sample.nu - mu)))
    assert abs(sample.nu[j] - mu) < 1e-14, (sample.nu, mu)
    assert sample.nu[-1] == 1.0
    r, _, t, _ = sample.rt_matrices()
    column = lambda m, k: float(sample.twonuw @ m[:, k])
    return (column(r, j), column(t, j)), (column(r, -1), column(t, -1))


def check_the_oblique_reading():
    for mu in (0.5, 0.2):
        for b in (0.5, 8.0):
            (r, t), _ = oblique_incidence(0.0, b, 0.0, mu, OBLIQUE_POINTS[0])
            assert abs(r) < 1e-12 and abs(t - math.exp(-b / mu)) < 1e-5, (mu, b, r, t)
    for a, b, g in SLABS:
        _, (r, t) = oblique_incidence(a, b, g, 0.5, OBLIQUE_POINTS[0])
        r1, t1 = normal_incidence(a, b, g, NORMAL_POINTS[0])
        assert abs(r - r1) < 1e-4 and abs(t - t1) < 1e-4, (a, b, g, r, r1, t, t1)


def case(a, b, g, mu):
    if mu == 1.0:
        (r, t), (r_check, t_check) = (normal_incidence(a, b, g, n) for n in NORMAL_POINTS)
        points = NORMAL_POINTS
    else:
        (r, t), (r_check, t_check) = (oblique_incidence(a, b, g, mu, n)[0] for n in OBLIQUE_POINTS)
        points = OBLIQUE_POINTS
    return {
        "albedo": a,
        "optical_thickness": b,
        "g": g,
        "mu": mu,
        "reflectance": r,
        "transmittance": t,
        "reflectance_tolerance": abs(r - r_check) + TOLERANCE_FLOOR,
        "transmittance_tolerance": abs(t - t_check) + TOLERANCE_FLOOR,
        "quadrature_points": points[0],
        "check_quadrature_points": points[1],
    }


def compute():
    check_the_oblique_reading()
    return {
        "description": "Total reflectance and transmittance (unscattered light included) of a plane-parallel "
        "slab with Henyey-Greenstein scattering, index 1 on both sides, for collimated light at cosine mu, "
        "by adding-doubling (iadpython). Read by random_walk::tests::index_matched_slabs_match_adding_doubling.",
        "command": "scripts/adding-doubling --write (in its environment: python notebooks/adding_doubling.py "
        "--write tests/data/adding_doubling.json)",
        "generator": "notebooks/adding_doubling.py",
        "iadpython_version": iad.__version__,
        "numpy_version": np.__version__,
        "scipy_version": scipy.__version__,
        "method": "normal incidence: Sample(a, b, g, n=1, quad_pts).rt(); oblique: the column of mu in the "
        "adding-doubling matrices on a quadrature that includes mu (see the script's docstring). Tolerance: "
        "the difference to a coarser quadrature plus 1e-5.",
        "cases": [case(a, b, g, mu) for a, b, g in SLABS for mu in COSINES],
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", metavar="JSON")
    mode.add_argument("--check", metavar="JSON")
    args = parser.parse_args()
    data = compute()
    if args.write:
        with open(args.write, "w") as f:
            json.dump(data, f, indent=1)
            f.write("\n")
        print(f"wrote {len(data['cases'])} cases to {args.write}")
        return 0
    with open(args.check) as f:
        committed = json.load(f)
    problems = []
    if committed["iadpython_version"] != data["iadpython_version"]:
        problems.append(f"iadpython {data['iadpython_version']}, the file was made with {committed['iadpython_version']}")
    if len(committed["cases"]) != len(data["cases"]):
        problems.append(f"{len(data['cases'])} cases, the file has {len(committed['cases'])}")
    for old, new in zip(committed["cases"], data["cases"]):
        for key, value in new.items():
            # Values agree to rounding across numpy/scipy versions; anything else is a change.
            if not math.isclose(old[key], value, rel_tol=1e-9, abs_tol=1e-12):
                problems.append(f"case a={new['albedo']} b={new['optical_thickness']} g={new['g']} "
                                f"mu={new['mu']}: {key} {old[key]} in the file, {value} computed")
    if problems:
        print(f"{args.check} does not match iadpython:", *problems, sep="\n  ", file=sys.stderr)
        print(f"regenerate it with: {data['command']}", file=sys.stderr)
        return 1
    print(f"{args.check}: all {len(data['cases'])} cases match iadpython {data['iadpython_version']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
