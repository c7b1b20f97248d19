"""Numbers in one plain format (issue 50, item 7): the repr of a Geodesic prints its length and
energy as the CLI prints numbers (qcshape::numfmt: fixed-point in [1e-4, 1e6), the exponent form
1.234e-5 otherwise), not as 4.110770e-1."""

import re

import qcshape as qs


def plain(value, x):
    """Whether the text value is x in the plain format with 7 significant digits."""
    if 1e-4 <= abs(x) < 1e6:
        ok = "e" not in value
    else:
        m = re.fullmatch(r"-?([1-9])\.\d+e(-?[1-9]\d*)", value)
        ok = m is not None
    return ok and abs(float(value) - x) <= 1e-6 * abs(x)


def test_geodesic_repr_prints_plain_numbers(pair):
    VA, VB, F = pair
    g = qs.ShapeSpace(F, lam=1e-4).geodesic(VA, VB, steps=2)
    r = repr(g)
    fields = dict(re.findall(r"(\w+)=([^,)]+)", r))
    assert plain(fields["length"], g.length), r
    assert plain(fields["energy"], g.energy), r
    assert fields["steps"] == "2" and fields["converged"] in ("True", "False"), r
