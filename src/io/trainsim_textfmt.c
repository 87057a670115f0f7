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
