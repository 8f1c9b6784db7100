/* ivoct ray — the list of method names for messages (the names themselves are
 * ray_method_name's, beside the root finders). */
#include <stdio.h>

#include "ray.h"

char *ray_method_list(char *buf, size_t n)
{
    if (!buf || n == 0)
        return buf;
    buf[0] = '\0';
    size_t len = 0;
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        const char *sep = m == 0 ? "" : m == RAY_METHOD_COUNT - 1 ? " or " : ", ";
        int w = snprintf(buf + len, n - len, "%s%s", sep, ray_method_name((ray_method_t)m));
        if (w < 0 || (size_t)w >= n - len)
            break;
        len += (size_t)w;
    }
    return buf;
}
