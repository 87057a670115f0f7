/* A real in Fortran's ESw.d form without Fortran's formatted I/O (trainsim_text_out):
 * C's %.*E gives the same correctly rounded digits as gfortran's ES edit descriptor
 * (which itself calls snprintf, asking for many more digits), at a fraction of the
 * cost. The caller checks the length and takes Fortran's own write for what this
 * form does not cover (non-finite values, three-digit exponents). */
#include <stdio.h>

int trainsim_fmt_e(double x, int d, char *buf, int cap)
{
    return snprintf(buf, (size_t)cap, "%.*E", d, x);
}

/* A real in Fortran's Fw.d form (the caller checks as above). */
int trainsim_fmt_f(double x, int d, char *buf, int cap)
{
    return snprintf(buf, (size_t)cap, "%.*f", d, x);
}

/* The value of a number the deck lexer has already checked ([sign] digits [. digits]
 * [e [sign] digits], n characters, not NUL-terminated): glibc's strtod, correctly
 * rounded, the conversion gfortran's list-directed read ends in. *ok = 0 if the text
 * is too long for this buffer (the caller then reads it with Fortran). */
#include <stdlib.h>
#include <string.h>

double trainsim_strtod(const char *s, int n, int *ok)
{
    char buf[128];
    if (n <= 0 || n >= (int)sizeof buf) {
        *ok = 0;
        return 0.0;
    }
    memcpy(buf, s, (size_t)n);
    buf[n] = '\0';
    *ok = 1;
    return strtod(buf, NULL);
}

/* Number of leading bytes of the n bytes at s that are ASCII and not NUL (1..127):
 * the deck's UTF-8 check (invalid_text_byte) starts its byte-by-byte walk there. Eight
 * bytes a step: a word has a byte >= 128 if (w & 0x80..80) is not 0, and a zero byte if
 * ((w - 0x01..01) & ~w & 0x80..80) is not 0. */
#include <stdint.h>

size_t trainsim_ascii_prefix(const char *s, size_t n)
{
    const uint64_t ones = 0x0101010101010101u, highs = 0x8080808080808080u;
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t w;
        memcpy(&w, s + i, 8);
        if ((w & highs) != 0 || ((w - ones) & ~w & highs) != 0)
            break;
    }
    while (i < n && (unsigned char)s[i] >= 1 && (unsigned char)s[i] < 128)
        i++;
    return i;
}
