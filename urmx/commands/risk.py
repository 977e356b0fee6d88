"""``urmx risk FILE.nc --hazard curve.csv [--years 50] [--spectrum design.csv]``: the collapse
risk of every wall and diaphragm of an IDA archive at a site, from the capacities the archive
holds (no new analyses), with where each rate comes from (its deaggregation by intensity and
the share from beyond the hazard file's computed intensities); or ``urmx risk --median M
--dispersion B --im IM --hazard curve.csv`` for one fragility given by hand, which must be
in the hazard curve's measure. A thin command over `urmx.analysis.ida`."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "risk", help="annual rate and probability of collapse of an IDA archive's walls at a "
                     "site (no new analyses)",
        description="Integrates each wall's collapse fragility (refitted in the hazard "
                    "curve's intensity measure from the scale factors at collapse the archive "
                    "holds) over a hazard curve: the mean annual frequency of collapse with "
                    "its 90 % studentized bootstrap interval (whole stations resampled where "
                    "the records carry a group) and the probability of collapse in --years, "
                    "per wall and diaphragm, and where each rate comes from (bands of "
                    "intensity, the share beyond the curve's last computed intensity); the "
                    "change when the diaphragm is stiffened (D1 -> D4); with --spectrum, the "
                    "median capacity in sa_wall over the design Sa at the wall's rocking "
                    "period. Prints Markdown tables. Without an archive, --median, "
                    "--dispersion and --im give one fragility.")
    p.add_argument("archive", metavar="FILE.nc", nargs="?", help="IDA archive (`urmx run`)")
    p.add_argument("--hazard", required=True, metavar="CURVE.csv",
                   help="hazard curve: CSV with the header 'pga [g],annual_rate [1/yr]' (the "
                        "measure: pga, pgv, sa_wall, sa_diaphragm, sa_avg or sa(T)), e.g. "
                        "catalog/hazard/illustrative-pga-hazard.csv, or an OpenQuake engine "
                        "hazard_curve-*.csv (PGA, PGV, SA(T), AvgSA)")
    p.add_argument("--site", type=int, default=0,
                   help="row of the site in an OpenQuake hazard-curve file (default 0)")
    p.add_argument("--years", type=float, default=50.0,
                   help="exposure time of the probability of collapse [yr] (default 50)")
    p.add_argument("--spectrum", metavar="DESIGN.csv",
                   help="design spectrum: CSV with the header 'period [s],sa [g]', e.g. "
                        "catalog/hazard/illustrative-design-spectrum.csv")
    p.add_argument("--median", type=float,
                   help="median of a fragility given by hand (g for accelerations, m/s "
                        "for pgv), instead of an archive")
    p.add_argument("--dispersion", type=float, help="its dispersion beta")
    p.add_argument("--im", help="its intensity measure (pga, pgv, sa_avg, sa(0.3), ...)")
    p.set_defaults(handler=_risk)


def _risk(args) -> int:
    from pathlib import Path

    from ..analysis.ida import first_cor
    from ..errors import InputError
    from ..reports.ida import open_ida
    from ..reports.ida_risk import risk_lines, risk_numbers

    if args.archive is None:
        return _one_fragility(args)
    if args.median is not None or args.dispersion is not None or args.im is not None:
        raise InputError("give an archive or --median/--dispersion/--im, not both")
    ds = open_ida(args.archive)
    r = risk_numbers(ds, args.hazard, args.spectrum, args.years, site=args.site)
    if r is None:
        from ..analysis.ida import require_measures

        require_measures(ds)  # raises: the archive lacks the measures
    print(f"# Collapse risk: {ds.attrs.get('study_name', Path(args.archive).name)} over "
          f"{r['curve'].source} ({r['curve'].im}), {args.years:g} years, COR "
          f"{float(first_cor(ds).cor):g}\n")
    print("\n".join(risk_lines(ds, r, heading="##")))
    return 0


def _one_fragility(args) -> int:
    """The rate of one fragility given by hand, refused when not in the curve's measure."""
    from ..errors import InputError
    from ..fragility import collapse_rate, read_hazard
    from ..fragility.fits import LognormalFit
    from ..fragility.risk import measure, measure_units
    from ..records.readers import STANDARD_GRAVITY

    if args.median is None or args.dispersion is None or args.im is None:
        raise InputError("give an IDA archive, or --median, --dispersion and --im of one "
                         "fragility")
    im = measure(args.im, "--im")
    factor = STANDARD_GRAVITY if measure_units(im) == "m s-2" else 1.0
    curve = read_hazard(args.hazard, args.site)
    fit = LognormalFit(args.median * factor, args.dispersion, 0, im=im,
                       units=measure_units(im))
    r = collapse_rate(fit, curve, args.years)
    unit = "g" if factor != 1.0 else curve.units
    print(f"# Collapse risk of a fragility in {im} (median {args.median:g} {unit}, beta "
          f"{args.dispersion:g}) over {curve.source}\n")
    print(f"Mean annual frequency of collapse {r.rate:.3g} per year; probability in "
          f"{args.years:g} years {100 * r.probability:.3g} %.\n")
    print(f"Share from beyond the last computed intensity ({_last(curve, factor, unit)}): "
          f"{100 * r.extrapolated_share:.3g} %.\n")
    print(f"| intensity band [{unit}] | share of the rate |\n|---|---|")
    for lo, hi, share in r.bands:
        print(f"| {lo / factor:.3g}-{hi / factor:.3g} | {100 * share:.3g} % |")
    return 0


def _last(curve, factor: float, unit: str) -> str:
    x = curve.intensity[-1] if curve.computed_to is None else curve.computed_to
    return f"{x / factor:.3g} {unit}"
