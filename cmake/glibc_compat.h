/*
 * Force-included (-include) into every C file of a Linux build: binds the libm functions whose
 * default symbol version is newer than glibc 2.28 to their oldest version, so that the binaries
 * (the FMUs above all) load on glibc 2.28 (RHEL 8) and later, not only on the build machine's.
 *
 * glibc 2.29 gave exp, exp2, log, log2 and pow new default versions (the same code without the
 * SVID error wrapper) and glibc 2.35 did the same for hypot; the old versions remain exported by
 * every later libm and compute the same values. tests/c/check_glibc_versions.cmake lists the
 * versions the FMU binaries require and fails above 2.28.
 */
#ifndef RRR_GLIBC_COMPAT_H
#define RRR_GLIBC_COMPAT_H
/* CMake adds it only where the C library is glibc; it includes nothing, so that the feature-test
 * macros a file defines before its first #include still take effect. */
#if defined(__linux__) && !defined(__ASSEMBLER__)
#if defined(__x86_64__)
#define RRR_GLIBC_BASE "GLIBC_2.2.5"
#elif defined(__aarch64__)
#define RRR_GLIBC_BASE "GLIBC_2.17"
#endif
#ifdef RRR_GLIBC_BASE
__asm__(".symver hypot,hypot@" RRR_GLIBC_BASE);
__asm__(".symver exp,exp@" RRR_GLIBC_BASE);
__asm__(".symver exp2,exp2@" RRR_GLIBC_BASE);
__asm__(".symver log,log@" RRR_GLIBC_BASE);
__asm__(".symver log2,log2@" RRR_GLIBC_BASE);
__asm__(".symver pow,pow@" RRR_GLIBC_BASE);
#endif
#endif
#endif /* RRR_GLIBC_COMPAT_H */
