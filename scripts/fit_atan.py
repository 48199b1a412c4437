#!/usr/bin/python3
"""Derives the coefficients of radlab's inline atan (formfactor/integrate/fast_atan.h).

    atan(u) ~ u + u^3 * P(u^2),   |u| <= tan(pi/8) (plus a small margin),

P a polynomial of degree DEGREE in z = u^2, chosen by the Remez exchange algorithm to minimise
the largest *relative* error of the whole approximation,

    max |(u + u^3 P(z) - atan u) / atan u| = max |w(z) (P(z) - g(z))|,
    g(z) = (atan u - u) / u^3,   w(z) = u^3 / atan u,

computed with mpmath at 60 digits. The coefficients are then rounded to double and the rounded
polynomial's relative error is measured again on a dense grid (also in mpmath): it is what the
C++ code uses. Also printed: pi/4 as hi + lo (hi the nearest double, lo the nearest double to
the rest) and hi's number of significant bits: the range reduction adds k hi + k lo for k = 0..4,
exact for hi only if it has at most 51 bits.

Run: /usr/bin/python3 scripts/fit_atan.py   (needs python3-mpmath only; takes a few seconds)
"""
import mpmath as mp

mp.mp.dps = 60
DEGREE = 10  # P has DEGREE + 1 coefficients: 10 gives 2.5e-18 (9: 4.4e-17, 8: 1.2e-15)
U_MAX = mp.tan(mp.pi / 8) * (1 + mp.mpf("0.01"))  # margin: the C++ region tests round
Z_MAX = U_MAX**2


def g(z):
    u = mp.sqrt(z)
    if z < mp.mpf("1e-12"):  # series: -1/3 + z/5 - z^2/7 + ... (avoids the cancellation)
        return sum((-1) ** (k + 1) * z**k / (2 * k + 3) for k in range(0, 8))
    return (mp.atan(u) - u) / u**3


def w(z):
    u = mp.sqrt(z)
    if z == 0:
        return mp.mpf(0)
    return u**3 / mp.atan(u)


def poly(c, z):
    return mp.polyval(list(reversed(c)), z)


def error(c, z):
    return w(z) * (poly(c, z) - g(z))


def remez(degree, iterations=30):
    n = degree + 2  # alternation points
    # Chebyshev extrema of [0, Z_MAX] as the first reference (z = 0 excluded: w vanishes there).
    ref = [Z_MAX * (1 - mp.cos(mp.pi * (i + 0.5) / n)) / 2 for i in range(n)]
    grid = [Z_MAX * (1 - mp.cos(mp.pi * i / 4000)) / 2 for i in range(1, 4001)]
    c = None
    for _ in range(iterations):
        # Solve w(z_i) (P(z_i) - g(z_i)) = (-1)^i E for the coefficients and E.
        a = mp.matrix(n, n)
        b = mp.matrix(n, 1)
        for i, z in enumerate(ref):
            for k in range(degree + 1):
                a[i, k] = w(z) * z**k
            a[i, degree + 1] = -((-1) ** i)
            b[i] = w(z) * g(z)
        x = mp.lu_solve(a, b)
        c = [x[k] for k in range(degree + 1)]
        # New reference: the extremum of each sign-alternating run of the error on the grid.
        values = [(z, error(c, z)) for z in grid]
        runs, current = [], [values[0]]
        for z, e in values[1:]:
            if (e >= 0) == (current[-1][1] >= 0):
                current.append((z, e))
            else:
                runs.append(current)
                current = [(z, e)]
        runs.append(current)
        extrema = [max(run, key=lambda t: abs(t[1])) for run in runs]
        # Keep n consecutive extrema with the largest smallest magnitude.
        best = max(
            (extrema[s : s + n] for s in range(len(extrema) - n + 1)),
            key=lambda window: min(abs(t[1]) for t in window),
        )
        ref = [t[0] for t in best]
    return c


def main():
    c = remez(DEGREE)
    doubles = [float(v) for v in c]
    worst = mp.mpf(0)
    for i in range(1, 20001):
        u = U_MAX * i / 20000
        z = u * u
        approx = u + u**3 * poly([mp.mpf(d) for d in doubles], z)
        worst = max(worst, abs(approx / mp.atan(u) - 1))
    print(f"// degree {DEGREE} in u^2 on |u| <= {mp.nstr(U_MAX, 8)}; max relative error of the "
          f"double coefficients (exact arithmetic): {mp.nstr(worst, 3)}")
    for k, d in enumerate(doubles):
        print(f"  {d!r:>25},  // u^{2 * k + 3}")
    quarter = mp.pi / 4
    hi = float(quarter)
    lo = float(quarter - mp.mpf(hi))
    mantissa = int(mp.mpf(hi) * 2**53)  # hi in [0.5, 1): 53 bits
    bits = 53 - (mantissa & -mantissa).bit_length() + 1
    print(f"  pi/4: hi {hi!r} ({bits} significant bits), lo {lo!r}")


if __name__ == "__main__":
    main()
