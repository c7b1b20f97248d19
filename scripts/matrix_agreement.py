#!/usr/bin/env python3
"""Agreement of two distance matrices of the same deformations (Python standard library only).

    python3 scripts/matrix_agreement.py ORIGINAL.csv FITTED.csv LABELS.csv

ORIGINAL.csv and FITTED.csv are distance matrices as `qcshape similarity` and `qcshape lv run`
write them (header `name,<name_1>,...,<name_n>`, one row per deformation; the rows of FITTED are
matched to ORIGINAL by name). LABELS.csv is `name,label` (a cohort's labels.csv) or a data set
manifest (`deformation,label,pose,path`).

Prints one line per quantity (`key value`): the Spearman rank correlation of the n(n-1)/2 pair
distances (average ranks for ties), the leave-one-out 1-nearest-neighbour accuracy of each matrix
against the labels, the share of deformations whose 1-NN label is the same under both matrices,
the subjects where they differ, and the median ratio fitted / original of the pair distances.
Used by scripts/lv_refit.sh (docs/fit.md, "The LV phantom cohort re-triangulated").
"""

import csv
import sys


def read_matrix(path):
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r]
    names = rows[0][1:]
    index = {r[0]: [float(x) for x in r[1:]] for r in rows[1:]}
    if sorted(index) != sorted(names):
        sys.exit(f"{path}: row names differ from the header")
    return names, [index[n] for n in names]


def read_labels(path):
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r]
    return {r[0]: r[1] for r in rows[1:]}


def ranks(x):
    order = sorted(range(len(x)), key=lambda i: x[i])
    r = [0.0] * len(x)
    k = 0
    while k < len(order):
        m = k
        while m + 1 < len(order) and x[order[m + 1]] == x[order[k]]:
            m += 1
        for i in order[k : m + 1]:
            r[i] = (k + m) / 2 + 1
        k = m + 1
    return r


def pearson(a, b):
    n = len(a)
    ma, mb = sum(a) / n, sum(b) / n
    sab = sum((x - ma) * (y - mb) for x, y in zip(a, b))
    saa = sum((x - ma) ** 2 for x in a)
    sbb = sum((y - mb) ** 2 for y in b)
    return sab / (saa * sbb) ** 0.5


def nearest_labels(d, labels):
    """Leave-one-out 1-NN prediction of each row (the first of equidistant neighbours)."""
    out = []
    for i in range(len(d)):
        j = min((j for j in range(len(d)) if j != i), key=lambda j: d[i][j])
        out.append(labels[j])
    return out


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    names, a = read_matrix(sys.argv[1])
    names_b, b_raw = read_matrix(sys.argv[2])
    if sorted(names) != sorted(names_b):
        sys.exit("the two matrices hold different deformations")
    pos = {n: k for k, n in enumerate(names_b)}
    b = [[b_raw[pos[r]][pos[c]] for c in names] for r in names]
    lab = read_labels(sys.argv[3])
    labels = [lab[n] for n in names]
    n = len(names)
    ua = [a[i][j] for i in range(n) for j in range(i + 1, n)]
    ub = [b[i][j] for i in range(n) for j in range(i + 1, n)]
    pa, pb = nearest_labels(a, labels), nearest_labels(b, labels)
    ratios = sorted(y / x for x, y in zip(ua, ub) if x > 0)
    print(f"deformations {n}")
    print(f"spearman {pearson(ranks(ua), ranks(ub)):.4f}")
    print(f"pearson {pearson(ua, ub):.4f}")
    print(f"median_ratio_fitted_over_original {ratios[len(ratios) // 2]:.4f}")
    print(f"nn_accuracy_original {sum(p == t for p, t in zip(pa, labels)) / n:.4f}")
    print(f"nn_accuracy_fitted {sum(p == t for p, t in zip(pb, labels)) / n:.4f}")
    print(f"nn_label_agreement {sum(p == q for p, q in zip(pa, pb)) / n:.4f}")
    differ = [f"{names[i]}({labels[i]}:{pa[i]}->{pb[i]})" for i in range(n) if pa[i] != pb[i]]
    print(f"nn_labels_differ {' '.join(differ) if differ else 'none'}")


if __name__ == "__main__":
    main()
