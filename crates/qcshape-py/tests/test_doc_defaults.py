"""docs/python.md agrees with the code on the estimators' constructor defaults (issue 50, item 8):
the doc's table of `KMeans` / `KMedoids` keywords and defaults equals `inspect.signature`, the
stub's signature and a fresh estimator's attributes, and every `n_clusters=N` the doc mentions is
the default."""

import ast
import inspect
import re
from pathlib import Path

import pytest

import qcshape as qs

ROOT = Path(__file__).resolve().parents[3]
DOC = ROOT / "docs" / "python.md"
STUB = ROOT / "crates" / "qcshape-py" / "python" / "qcshape" / "__init__.pyi"
ESTIMATORS = ["KMeans", "KMedoids"]


def doc_defaults():
    """{keyword: default} from the table after "Constructor defaults of `KMeans` and `KMedoids`"."""
    text = DOC.read_text()
    start = text.index("Constructor defaults of `KMeans` and `KMedoids`")
    rows = {}
    for line in text[start:].splitlines()[1:]:
        if rows and not line.startswith("|"):
            break
        m = re.fullmatch(r"\|\s*`(\w+)`\s*\|\s*`(.+?)`\s*\|", line.strip())
        if m:
            rows[m.group(1)] = ast.literal_eval(m.group(2))
    assert rows, "docs/python.md: no defaults table"
    return rows


def stub_defaults(name):
    tree = ast.parse(STUB.read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == name)
    init = next(n for n in cls.body if isinstance(n, ast.FunctionDef) and n.name == "__init__")
    a = init.args
    positional = a.args[1:]
    out = dict(zip([p.arg for p in positional[len(positional) - len(a.defaults):]],
                   [ast.literal_eval(d) for d in a.defaults]))
    out.update({p.arg: ast.literal_eval(d) for p, d in zip(a.kwonlyargs, a.kw_defaults) if d is not None})
    return out


@pytest.mark.parametrize("name", ESTIMATORS)
def test_doc_defaults_equal_the_signature(name):
    cls = getattr(qs, name)
    sig = {p.name: p.default for p in inspect.signature(cls.__init__).parameters.values() if p.name != "self"}
    assert doc_defaults() == sig


@pytest.mark.parametrize("name", ESTIMATORS)
def test_doc_defaults_equal_the_stub_and_a_fresh_estimator(name):
    expected = doc_defaults()
    assert stub_defaults(name) == expected
    est = getattr(qs, name)()
    assert {k: getattr(est, k) for k in expected} == expected
    assert est.get_params() == expected


def test_every_n_clusters_the_doc_mentions_is_the_default():
    default = doc_defaults()["n_clusters"]
    text = DOC.read_text()
    said = [int(v) for v in re.findall(r"n_clusters\s*=\s*(\d+)", text)]
    said += [int(v) for v in re.findall(r"\bk = (\d+)", text)]
    assert said and all(v == default for v in said), said
