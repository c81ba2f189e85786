"""Taylor series of functions of small matrices (the exponential and the phi-functions) for steps of any length: the
powers of the matrix are kept per power of 2 of the step, h^j a^j = r^j (s a)^j with r = h / s, so a new step length
(a host that varies its step) costs one weighted sum per entry instead of a series of matrix products. Standard
library only: runs inside the FMUs (the Motor's exact PI step, the exponential integrators of the twin rotors and
the double Cardan driveline), with the polynomial coefficients of their exponential Adams methods."""

import functools
import itertools
import math
import operator
from collections.abc import Sequence

#: terms of the series at most
TERMS = 34
#: 1 / j! for j < TERMS + 8 (phi_k up to phi_7 take (j + k)!)
_INVERSE_FACTORIALS = tuple(1.0 / math.factorial(j) for j in range(TERMS + 8))


@functools.lru_cache(maxsize=128)
def scaled_powers(a: tuple, scale: float, ratio: float) -> tuple:
    """Per entry (i, c) of the square matrix a, the tuple of the entries (i, c) of (scale a)^j for the terms that
    count: j < TERMS, up to the last whose largest entry times ratio^j / j! exceeds 1e-22 (ratio: the largest
    r = h / scale its caller takes; the functions' entries are O(1))."""
    n = len(a)
    x = [[scale * v for v in row] for row in a]
    power = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    matrices, terms, bound = [power], 1, 1.0
    columns = list(zip(*x))
    for j in range(1, TERMS):
        power = [[sum(map(operator.mul, row, column)) for column in columns] for row in power]
        matrices.append(power)
        bound *= ratio / j
        if max(abs(v) for row in power for v in row) * bound > 1e-22:
            terms = j + 1
    return tuple(tuple(tuple(m[i][c] for m in matrices[:terms]) for c in range(n)) for i in range(n))


@functools.lru_cache(maxsize=64)
def series_weights(r: float, coefficients: tuple) -> tuple:
    """The weight of (s a)^j in sum_k coefficients[k] phi_k(r s a), phi_k(X) = sum_j X^j / (j + k)! (phi_0 = exp):
    r^j sum_k coefficients[k] / (j + k)!, j < TERMS."""
    sums = (0.0,) * TERMS
    for k, c in enumerate(coefficients):
        if c:
            sums = map(operator.add, sums, map(operator.mul, itertools.repeat(c), _INVERSE_FACTORIALS[k:]))
    return tuple(map(operator.mul, sums, itertools.accumulate(itertools.repeat(r, TERMS - 1), operator.mul,
                                                              initial=1.0)))


def weighted(powers: tuple, weights: tuple, columns=None) -> list:
    """sum_j weights[j] (s a)^j from :func:`scaled_powers`, row by row (only the given columns, default all)."""
    if columns is None:
        return [[sum(map(operator.mul, weights, entry)) for entry in row] for row in powers]
    return [[sum(map(operator.mul, weights, row[c])) for c in columns] for row in powers]


def phi_sum(a: tuple, h: float, coefficients: tuple, columns: Sequence[int] | None = None) -> list:
    """sum_k coefficients[k] phi_k(h a) of a small square matrix a, row by row (only the given columns, default
    all), phi_k(X) = sum_j X^j / (j + k)! (phi_0 = exp), by the Taylor series (above), for h |lambda| <= 1 over
    a's eigenvalues (the twin rotors' substep rule; the double Cardan chooses between this and
    :func:`phi_sum_stiff`), where its truncation is below 1e-22. X^j = r^j (s a)^j with s the power of 2 nearest
    h, so r = h / s <= 1.5 (the powers of s a kept per (a, s))."""
    scale = 2.0 ** round(math.log2(h))
    return weighted(scaled_powers(a, scale, 1.5), series_weights(h / scale, coefficients), columns)


def lagrange_coefficients(nodes: Sequence[float]) -> list:
    """c[j][m]: the coefficient of theta^m of the Lagrange basis polynomial of nodes[j] (1 there, 0 at the others)."""
    rows = []
    for j, node in enumerate(nodes):
        poly, scale = [1.0], 1.0
        for i, other in enumerate(nodes):
            if i != j:   # poly *= (theta - other)
                poly = [(poly[m - 1] if m else 0.0) - other * (poly[m] if m < len(poly) else 0.0)
                        for m in range(len(poly) + 1)]
                scale *= node - other
        rows.append([c / scale for c in poly])
    return rows


def newton_coefficients(nodes: Sequence[float]) -> list:
    """Coefficients of theta^m of prod_j (theta - node_j) / prod_j (1 - node_j): 0 at the nodes, 1 at theta = 1."""
    poly, scale = [1.0], 1.0
    for other in nodes:
        poly = [(poly[m - 1] if m else 0.0) - other * (poly[m] if m < len(poly) else 0.0) for m in range(len(poly) + 1)]
        scale *= 1.0 - other
    return [c / scale for c in poly]


def integral_coefficients(h: float, c: Sequence[float]) -> tuple:
    """The coefficients of phi_k (:func:`phi_sum`) in h sum_m c_m m! phi_(m+1)(h L), the variation-of-constants
    integral h int_0^1 exp((1 - theta) h L) sum_m c_m theta^m d theta."""
    return (0.0, *(h * cm * math.factorial(m) for m, cm in enumerate(c)))


def expm(generator: tuple, h: float) -> list:
    """exp(h G) of a small square matrix G (rows) = D exp(h B) D^-1, B = D^-1 G D balanced (:func:`balanced`):
    the Taylor series (:func:`weighted`) of X = h B / 2^q, ||X||_1 <= 1/2, squared q times. X = r (s B) with s the
    power of 2 at or below h / 2^q, so r < 2. Computed in plain Python: the Motor's exact PI step, the stiff
    blocks' phi-functions (:func:`phi_functions`)."""
    b, d = balanced(generator)
    norm = max(map(sum, zip(*([abs(v) for v in row] for row in b))))
    q = math.ceil(math.log2(2.0 * h * norm)) if h * norm > 0.5 else 0
    hq = h / 2.0 ** q
    scale = 2.0 ** math.floor(math.log2(hq))
    total = weighted(scaled_powers(b, scale, 2.0), series_weights(hq / scale, (1.0,)))
    for _ in range(q):
        columns = list(zip(*total))
        total = [[sum(map(operator.mul, row, column)) for column in columns] for row in total]
    return [[d[i] * v / d[c] for c, v in enumerate(row)] for i, row in enumerate(total)]


@functools.lru_cache(maxsize=32)
def balanced(generator: tuple) -> tuple:
    """(B, d): B = D^-1 G D with D = diag(d), d powers of 2 (exact), each row's and column's off-diagonal sums within
    a factor 2 of each other where that lowers their sum by 5% (Parlett, Reinsch, "Balancing a matrix for calculation
    of eigenvalues and eigenvectors", Numer. Math. 13, 1969): ||B||_1 is what sets the squarings of :func:`expm`
    (the PI loop's Ki/J entry makes ||G||_1 far larger than its rates)."""
    n = len(generator)
    b, d = [list(row) for row in generator], [1.0] * n
    for _ in range(100):
        done = True
        for i in range(n):
            c = sum(abs(b[j][i]) for j in range(n) if j != i)
            r = sum(abs(b[i][j]) for j in range(n) if j != i)
            if c == 0.0 or r == 0.0:
                continue
            total, f = c + r, 1.0
            while c < 0.5 * r:
                c, r, f = 2.0 * c, 0.5 * r, 2.0 * f
            while c >= 2.0 * r:
                c, r, f = 0.5 * c, 2.0 * r, 0.5 * f
            if c + r < 0.95 * total:
                done = False
                d[i] *= f
                for j in range(n):
                    b[i][j] /= f
                    b[j][i] *= f
        if done:
            break
    return tuple(map(tuple, b)), tuple(d)


@functools.lru_cache(maxsize=32)
def phi_functions(a: tuple, h: float, order: int) -> tuple:
    """(phi_0(h a), ..., phi_order(h a)) of a small square matrix a, each a tuple of rows, at any h |a|: the first
    block row of exp(W), W = [[h a, I, 0, ..., 0], [0, 0, I, ..., 0], ..., [0, ..., 0]] of order + 1 blocks
    (Sidje, "Expokit: a software package for computing matrix exponentials", ACM Trans. Math. Softw. 24, 1998,
    Theorem 1), by balancing, scaling and squaring (:func:`expm`). For steps beyond :func:`phi_sum`'s series (a
    stiff block: h |lambda| >> 1)."""
    n = len(a)
    m = n * (order + 1)
    w = [[0.0] * m for _ in range(m)]
    for i in range(n):
        for j in range(n):
            w[i][j] = h * a[i][j]
    for k in range(order):
        for i in range(n):
            w[k * n + i][(k + 1) * n + i] = 1.0
    total = expm(tuple(map(tuple, w)), 1.0)
    return tuple(tuple(tuple(total[i][k * n:(k + 1) * n]) for i in range(n)) for k in range(order + 1))


def phi_sum_stiff(a: tuple, h: float, coefficients: tuple, columns: Sequence[int] | None = None) -> list:
    """:func:`phi_sum` from :func:`phi_functions`: for any h |a|, at the cost of the exponential of one square
    matrix of n len(coefficients) rows (n = len(a)), kept per (a, h, order)."""
    phis = phi_functions(a, h, len(coefficients) - 1)
    picked = range(len(a)) if columns is None else columns
    return [[sum(c * phi[i][col] for c, phi in zip(coefficients, phis) if c) for col in picked] for i in range(len(a))]
