/* File-system queries that Fortran cannot make: the kind of a path without
 * following a final symbolic link (lstat). Used by trainsim_hdf5 so that `-o`
 * never replaces anything but a regular file. */
#include <errno.h>
#include <sys/stat.h>

/* 0 absent, 1 regular file, 2 directory, 3 symbolic link,
 * 4 anything else (device, fifo, socket), -1 cannot tell (errno other than ENOENT). */
int trainsim_path_kind(const char *path)
{
    struct stat st;
    if (lstat(path, &st) != 0)
        return (errno == ENOENT || errno == ENOTDIR) ? 0 : -1;
    if (S_ISLNK(st.st_mode))
        return 3;
    if (S_ISREG(st.st_mode))
        return 1;
    if (S_ISDIR(st.st_mode))
        return 2;
    return 4;
}
