// ivoct_bench_fmt: nanoseconds per number of fmt_g17 (fmt/fmt.h) against the
// formatters it replaces, on the same numbers in one run: libstdc++'s
// std::to_chars with 17 significant digits (the cell list's before) and
// glibc's snprintf("%.17g") (the definition).  Two sets of 2^20 numbers:
// floats in [-1.5, 1.5] (a cell list's f_lo, f_hi) and doubles spread
// log-uniformly over [1e-6, 1e3] (its coordinates, error bounds, slabs).
// Each timing is the minimum over --reps passes (default 5).  Also checks that
// the three write the same characters (exit 1 if not).
//
//   ivoct_bench_fmt [--reps N]
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "fmt/fmt.h"

namespace {

uint64_t state = 0x9E3779B97F4A7C15u;
double uniform()
{
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return (double)(state >> 11) / 9007199254740992.0;
}

char *by_fmt(char *p, double x) { return fmt_g17(p, x); }
char *by_to_chars(char *p, double x)
{
    return std::to_chars(p, p + FMT_G17_ROOM, x, std::chars_format::general, 17).ptr;
}
char *by_snprintf(char *p, double x) { return p + std::snprintf(p, FMT_G17_ROOM, "%.17g", x); }

// ns per number, the minimum over reps passes; the characters' count in `total`
template <class F> double time_ns(const std::vector<double> &v, int reps, F f, size_t &total)
{
    std::vector<char> out(v.size() * FMT_G17_ROOM);
    double best = 1e300;
    for (int r = 0; r < reps; r++) {
        const auto t0 = std::chrono::steady_clock::now();
        char *p = out.data();
        for (double x : v)
            p = f(p, x);
        const auto t1 = std::chrono::steady_clock::now();
        total = (size_t)(p - out.data());
        best = std::min(best, std::chrono::duration<double, std::nano>(t1 - t0).count());
    }
    return best / (double)v.size();
}

}  // namespace

int main(int argc, char **argv)
{
    int reps = 5;
    for (int i = 1; i < argc; i++) {
        if (!std::strcmp(argv[i], "--reps") && i + 1 < argc) {
            reps = std::atoi(argv[++i]);
        } else {
            std::fprintf(stderr, "usage: ivoct_bench_fmt [--reps N]\n");
            return 2;
        }
    }
    if (reps < 1)
        reps = 1;
    const size_t n = (size_t)1 << 20;
    std::vector<double> floats(n), doubles(n);
    for (size_t i = 0; i < n; i++) {
        floats[i] = (float)((uniform() - 0.5) * 3);
        doubles[i] = std::pow(10.0, -6 + 9 * uniform());
    }
    int rc = 0;
    std::printf("set,fmt_g17_ns,to_chars_ns,snprintf_ns,to_chars_over_fmt\n");
    for (const auto *set : {&floats, &doubles}) {
        // the same characters from all three
        char a[FMT_G17_ROOM], b[FMT_G17_ROOM], c[FMT_G17_ROOM];
        for (double x : *set) {
            const size_t la = (size_t)(by_fmt(a, x) - a), lb = (size_t)(by_to_chars(b, x) - b),
                         lc = (size_t)(by_snprintf(c, x) - c);
            if (la != lc || lb != lc || std::memcmp(a, c, lc) || std::memcmp(b, c, lc)) {
                std::fprintf(stderr, "ivoct_bench_fmt: %a written differently\n", x);
                rc = 1;
                break;
            }
        }
        size_t ta = 0, tb = 0, tc = 0;
        const double fa = time_ns(*set, reps, by_fmt, ta);
        const double fb = time_ns(*set, reps, by_to_chars, tb);
        const double fc = time_ns(*set, 1, by_snprintf, tc);
        if (ta != tb || ta != tc)
            rc = 1;
        std::printf("%s,%.1f,%.1f,%.1f,%.2f\n", set == &floats ? "floats" : "doubles", fa, fb, fc,
                    fb / fa);
    }
    return rc;
}
