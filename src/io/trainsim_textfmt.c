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
