"""``urmx risk FILE.nc --hazard curve.csv [--years 50] [--spectrum design.csv]``: the collapse
risk of every wall and diaphragm of an IDA archive at a site, from the capacities the archive
holds (no new analyses): a thin command over `urmx.fragility_analysis`."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "risk", help="annual rate and probability of collapse of an IDA archive's walls at a "
                     "site (no new analyses)",
        description="Integrates each wall's collapse fragility (refitted in the hazard "
                    "curve's intensity measure from the scale factors at collapse the archive "
                    "holds) over a hazard curve: the mean annual frequency of collapse with "
                    "its 90 % bootstrap interval and the probability of collapse in --years, "
                    "per wall and diaphragm; the change when the diaphragm is stiffened "
                    "(D1 -> D4, single storey and higher storey); with --spectrum, the median "
                    "capacity in sa_wall over the design Sa at the wall's rocking period. "
                    "Prints Markdown tables.")
    p.add_argument("archive", metavar="FILE.nc", help="IDA archive (`urmx ida`)")
    p.add_argument("--hazard", required=True, metavar="CURVE.csv",
                   help="hazard curve: CSV with the header 'pga [g],annual_rate [1/yr]' (the "
                        "measure: pga, pgv, sa_wall, sa_diaphragm or sa_avg), e.g. "
                        "catalog/hazard/illustrative-pga-hazard.csv")
    p.add_argument("--years", type=float, default=50.0,
                   help="exposure time of the probability of collapse [yr] (default 50)")
    p.add_argument("--spectrum", metavar="DESIGN.csv",
                   help="design spectrum: CSV with the header 'period [s],sa [g]', e.g. "
                        "catalog/hazard/illustrative-design-spectrum.csv")
    p.set_defaults(handler=_risk)


def _risk(args) -> int:
    from pathlib import Path

    from ..fragility_analysis import first_cor
    from ..fragility_report import open_ida
    from ..risk_report import risk_lines, risk_numbers

    ds = open_ida(args.archive)
    r = risk_numbers(ds, args.hazard, args.spectrum, args.years)
    if r is None:
        from ..fragility_analysis import require_measures

        require_measures(ds)  # raises: the archive lacks the measures
    print(f"# Collapse risk: {ds.attrs.get('study_name', Path(args.archive).name)} over "
          f"{r['curve'].source} ({r['curve'].im}), {args.years:g} years, COR "
          f"{float(first_cor(ds).cor):g}\n")
    print("\n".join(risk_lines(ds, r, heading="##")))
    return 0
