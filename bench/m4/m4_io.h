/* SPDX-License-Identifier: Apache-2.0 */
/*
 * m4_io.h - the output of the bench/m4 programs, identical on the host and
 * on the Cortex-M4: a buffered text writer with hex and decimal formatting
 * and a running FNV-1a 64-bit hash of every byte written. The only
 * platform-specific piece is m4_io_write (io_host.c: stdout; io_mps2.c:
 * semihosting).
 */
#ifndef M4_IO_H
#define M4_IO_H

#include <stddef.h>
#include <stdint.h>

/** Platform hook: writes len bytes to the program's standard output.
 *  Returns 0 on success, -1 on error. */
int m4_io_write(const char *buf, size_t len);

/** Appends a NUL-terminated string. */
void m4_out_str(const char *s);

/** Appends " xxxxxxxx": a space and 8 lower-case hex digits of v. */
void m4_out_hex(uint32_t v);

/** Appends " xxxxxxxx" for each of n int32 words (two's complement bits). */
void m4_out_words(const int32_t *w, unsigned n);

/** Appends v in decimal (no space). */
void m4_out_u32(uint32_t v);

/** Appends v / 16 in decimal with one decimal (v carries 4 fractional bits:
 *  instruction counts from sp_mps2_counts_to_instr16), rounded to nearest. */
void m4_out_fix16(uint64_t v16);

/** Appends s left-aligned in a field of `width` characters. */
void m4_out_str_w(const char *s, unsigned width);

/** Appends v in decimal, right-aligned in a field of `width` characters. */
void m4_out_u32_w(uint32_t v, unsigned width);

/** m4_out_fix16 right-aligned in a field of `width` characters. */
void m4_out_fix16_w(uint64_t v16, unsigned width);

/** Appends 16 lower-case hex digits of v (no space). */
void m4_out_hex64(uint64_t v);

/** Appends a newline. */
void m4_out_nl(void);

/** Writes out the buffer. Returns 0, or -1 if any write so far failed. */
int m4_out_flush(void);

/** FNV-1a 64-bit hash of every byte appended so far (offset basis
 *  0xcbf29ce484222325, prime 0x100000001b3). */
uint64_t m4_out_hash(void);

#endif /* M4_IO_H */
