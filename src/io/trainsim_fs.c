/* File-system queries that Fortran cannot make: the kind of a path without
 * following a final symbolic link (lstat). Used by trainsim_hdf5 so that `-o`
 * never replaces anything but a regular file. */
#include <errno.h>
#include <stdlib.h>
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

/* ------------------------------------------------------------------------------------
 * The sweep file's writer lock (src/sweep/trainsim_sweep_file.f90, docs/sweeps.md).
 *
 * An flock(2) on `path` (FILE.lock beside the sweep file): the kernel releases it when
 * the holder ends in any way (kill -9 included), so a lock file left behind is never
 * stale, only unlocked; Linux maps flock to POSIX locks on NFS. The holder writes its
 * pid into the file (for the refusal message) and unlinks it when done; a process that
 * opened the file just before that unlink finds the path no longer names its file and
 * tries again. */
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/file.h>
#include <sys/statvfs.h>
#include <unistd.h>

/* An fd >= 0 holding the lock; -1 if another process holds it (*info = its pid, 0 if
 * not yet written); -2 if the lock file cannot be made (*info = errno). */
int trainsim_lock(const char *path, int *info)
{
    int attempt;
    *info = 0;
    for (attempt = 0; attempt < 100; ++attempt) {
        struct stat a, b;
        int fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (fd < 0) {
            *info = errno;
            return -2;
        }
        if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            int e = errno;
            if (e == EWOULDBLOCK) {
                char buf[32];
                ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
                if (n > 0) {
                    buf[n] = '\0';
                    *info = atoi(buf);
                }
                close(fd);
                return -1;
            }
            close(fd);
            *info = e;
            return -2;
        }
        if (fstat(fd, &a) == 0 && stat(path, &b) == 0 && a.st_ino == b.st_ino && a.st_dev == b.st_dev) {
            char buf[32];
            int n = snprintf(buf, sizeof buf, "%ld\n", (long)getpid());
            if (ftruncate(fd, 0) == 0 && n > 0 && pwrite(fd, buf, (size_t)n, 0) < 0) {
                /* the pid is only for messages */
            }
            return fd;
        }
        close(fd); /* unlinked by its last holder meanwhile: lock the new one */
    }
    *info = EAGAIN;
    return -2;
}

/* Release a lock of trainsim_lock: unlink first, so no one locks the old file after. */
void trainsim_unlock(int fd, const char *path)
{
    if (fd < 0)
        return;
    unlink(path);
    close(fd);
}

/* The text of errno `e` into buf (n bytes, NUL-terminated). */
void trainsim_strerror(int e, char *buf, int n)
{
    if (n <= 0)
        return;
    strncpy(buf, strerror(e), (size_t)n - 1);
    buf[n - 1] = '\0';
}

/* The current errno (what the last failed system call of HDF5 left). */
int trainsim_errno(void)
{
    return errno;
}

/* Bytes free to an unprivileged user on the file system holding `path`, -1 unknown. */
long long trainsim_free_bytes(const char *path)
{
    struct statvfs s;
    if (statvfs(path, &s) != 0)
        return -1;
    return (long long)s.f_bavail * (long long)s.f_frsize;
}

/* FNV-1a 64 of n bytes as 16 hex digits (and a NUL) in out: the sweep file's
 * fingerprints of its inputs. */
void trainsim_digest(const char *s, long long n, char *out)
{
    uint64_t h = 14695981039346656037ULL;
    long long i;
    for (i = 0; i < n; ++i) {
        h ^= (unsigned char)s[i];
        h *= 1099511628211ULL;
    }
    snprintf(out, 17, "%016llx", (unsigned long long)h);
}

/* Give the memory freed since the last call back to the system (glibc malloc_trim):
 * a sweep builds and frees a model per run, and the holes the allocator keeps would
 * otherwise raise its peak RSS with the number of runs (docs/benchmarks.md). */
#if defined(__GLIBC__)
#include <malloc.h>
void trainsim_trim_memory(void)
{
    malloc_trim(0);
}
#else
void trainsim_trim_memory(void)
{
}
#endif

/* Remove the temporaries FILE.<digits>.part of sweeps killed while creating FILE (only
 * the holder of FILE.lock makes one, so under the lock every such file is stale).
 * Returns how many were removed. */
#include <dirent.h>
int trainsim_remove_stale_parts(const char *path)
{
    char dir[4096];
    const char *base = strrchr(path, '/');
    size_t nb;
    DIR *d;
    struct dirent *e;
    int removed = 0;
    if (base) {
        size_t n = (size_t)(base - path);
        if (n == 0)
            n = 1;
        if (n >= sizeof dir)
            return 0;
        memcpy(dir, path, n);
        dir[n] = '\0';
        base++;
    } else {
        strcpy(dir, ".");
        base = path;
    }
    nb = strlen(base);
    d = opendir(dir);
    if (!d)
        return 0;
    while ((e = readdir(d)) != NULL) {
        const char *s = e->d_name, *p;
        size_t n = strlen(s);
        if (n <= nb + 6 || strncmp(s, base, nb) != 0 || s[nb] != '.' || strcmp(s + n - 5, ".part") != 0)
            continue;
        for (p = s + nb + 1; p < s + n - 5; ++p)
            if (*p < '0' || *p > '9')
                break;
        if (p == s + n - 5) {
            char full[8192];
            if (snprintf(full, sizeof full, "%s/%s", dir, s) < (int)sizeof full && unlink(full) == 0)
                ++removed;
        }
    }
    closedir(d);
    return removed;
}
