// vtk_number (export/htg_xml.cpp), the .htg's number formatting, against its
// oracle: VTK's own vtkNumberToString, which the .htg writer no longer loads
// VTK for.  Every value must give the same text:
//  - the edges of the notation: zeros, the exponents -7 to 22 around the switch
//    between decimal and exponential notation, powers of ten and their
//    neighbours over the whole range, subnormals, the extremes, NaN, infinities;
//  - 2 M doubles of random bits, and 1 M of the kind a range holds (integers,
//    quotients of small integers, values of an expression at a few digits).
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <locale>
#include <sstream>
#include <string>
#include <vector>

#include <vtkNumberToString.h>

#include "../export/internal.hpp"

namespace {

std::string oracle(double v)
{
    std::ostringstream s;
    s.imbue(std::locale::classic());
    s << vtkNumberToString()(v);
    return s.str();
}

uint64_t splitmix(uint64_t &state)
{
    uint64_t z = (state += 0x9e3779b97f4a7c15u);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
    return z ^ (z >> 31);
}

double from_bits(uint64_t b)
{
    double v;
    std::memcpy(&v, &b, sizeof v);
    return v;
}

size_t checked = 0, failed = 0;

void check(double v)
{
    checked++;
    const std::string got = ivexp::vtk_number(v), want = oracle(v);
    if (got != want && ++failed <= 20)
        std::fprintf(stderr, "vtk_number(%a) = \"%s\", vtkNumberToString says \"%s\"\n", v,
                     got.c_str(), want.c_str());
}

void check_both_signs(double v)
{
    check(v);
    check(-v);
}

}  // namespace

int main()
{
    const double inf = std::numeric_limits<double>::infinity();
    for (double v : {0.0, 1.0, 0.5, 0.1, 1.0 / 3.0, 2.0 / 3.0, 100.0, 123456.0, 1e-6, 1e-7,
                     9.999999e-7, 1.5e-6, 1e15, 1e16, 1e17, 9007199254740992.0, 1e20, 1e21, 1e22,
                     123456789012345678901.0, 1.2345678901234567e21, DBL_MAX, DBL_MIN,
                     DBL_TRUE_MIN, DBL_EPSILON, inf, std::nan("")})
        check_both_signs(v);
    // around the switch of notation, and every power of ten with its neighbours
    for (int e = -330; e <= 310; e++) {
        const double p = std::pow(10.0, e);
        for (double v : {p, std::nextafter(p, 0.0), std::nextafter(p, inf), 1.5 * p, 9.99 * p,
                         1.0000001 * p})
            check_both_signs(v);
    }
    for (int e = -1074; e <= 1023; e++)
        check_both_signs(std::ldexp(1.0, e));
    uint64_t state = 20261208;
    for (int i = 0; i < 2000000; i++)
        check(from_bits(splitmix(state)));
    for (int i = 0; i < 1000000; i++) {
        const uint64_t r = splitmix(state);
        const double a = (double)(int64_t)(r % 2000001) - 1000000.0;
        const double b = (double)(r >> 40 & 1023) + 1.0;
        switch (i % 4) {
        case 0: check(a); break;
        case 1: check(a / b); break;
        case 2: check(a / 1000.0); break;
        default: check(std::ldexp(a, -(int)(r >> 50 & 63))); break;
        }
    }
    std::printf("vtk_number: %zu values, %zu differ from vtkNumberToString\n", checked, failed);
    return failed ? 1 : 0;
}
