/* ivoct fmt — numbers as text: what printf writes, without printf's cost.
 *
 * The CSV of `ivoct build --cells` holds millions of doubles at 17
 * significant digits.  glibc's snprintf formats one in ~0.2 us (multi-precision
 * arithmetic), libstdc++'s std::to_chars in 60-70 ns; fmt_g17 writes the same
 * characters in 27-30 ns for the magnitudes a cell list holds, by one exact
 * integer product (bench/bench_fmt.cpp).  Plain C, usable from C++; never
 * prints, never fails. */
#ifndef IVOCT_FMT_H
#define IVOCT_FMT_H

#ifdef __cplusplus
extern "C" {
#endif

/* The longest text of fmt_g17 ("-1.2345678901234567e-308"), and the room it
 * needs: it may write scratch characters past the end it returns, up to
 * p + FMT_G17_ROOM (copies of fixed size are what make it fast). */
#define FMT_G17_MAX 24
#define FMT_G17_ROOM 40

/* Write x at p exactly as printf("%.17g", x) does in the C locale (17
 * significant digits, correctly rounded, ties to even; the text reads back to
 * x), without a terminating NUL; return the end.  p must have room for
 * FMT_G17_ROOM characters.  By a 64 x 128-bit integer product where
 * 2^-73 <= |x| < 2^53 (about 1e-22 to 9e15); zero directly; every other x
 * (subnormal, smaller, larger, infinite, NaN) through snprintf itself, its
 * decimal point made '.' whatever LC_NUMERIC says. */
char *fmt_g17(char *p, double x);

#ifdef __cplusplus
}
#endif

#endif
