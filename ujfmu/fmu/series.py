"""Taylor series of functions of small matrices (the exponential and the phi-functions) for steps of any length: the
powers of the matrix are kept per power of 2 of the step, h^j a^j = r^j (s a)^j with r = h / s, so a new step length
(a host that varies its step) costs one weighted sum per entry instead of a series of matrix products. Standard
library only: runs inside the FMUs (the Motor's exact PI step, the twin rotors' exponential integrators)."""

import functools
import itertools
import math
import operator

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
