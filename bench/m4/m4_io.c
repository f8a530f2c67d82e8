/* SPDX-License-Identifier: Apache-2.0 */
/*
 * m4_io.c - buffered text output with a running FNV-1a hash (m4_io.h).
 * Portable C, no libc formatting: the host and the Cortex-M4 produce the
 * same bytes by construction.
 */
#include "m4_io.h"

#define OUT_BUFFER 4096u

static char buffer[OUT_BUFFER];
static size_t used;
static int failed;
static uint64_t hash = UINT64_C(0xcbf29ce484222325);

static void flush_buffer(void)
{
    if (used > 0u && m4_io_write(buffer, used) != 0) {
        failed = 1;
    }
    used = 0u;
}

static void put_char(char c)
{
    if (used == OUT_BUFFER) {
        flush_buffer();
    }
    buffer[used++] = c;
    hash = (hash ^ (uint8_t)c) * UINT64_C(0x100000001b3);
}

void m4_out_str(const char *s)
{
    while (*s != '\0') {
        put_char(*s++);
    }
}

static void put_hex_digits(uint64_t v, unsigned digits)
{
    static const char hex[] = "0123456789abcdef";
    unsigned i;
    for (i = digits; i-- > 0u;) {
        put_char(hex[(v >> (4u * i)) & 0xFu]);
    }
}

void m4_out_hex(uint32_t v)
{
    put_char(' ');
    put_hex_digits(v, 8u);
}

void m4_out_words(const int32_t *w, unsigned n)
{
    unsigned i;
    for (i = 0u; i < n; ++i) {
        m4_out_hex((uint32_t)w[i]);
    }
}

/* Formats v in decimal, optionally with one decimal (v in tenths), into
 * text (at least 24 bytes), NUL-terminated; returns the length. */
static unsigned format_decimal(uint64_t v, int tenths, char *text)
{
    char digits[22];
    unsigned n = 0u;
    unsigned len = 0u;
    if (tenths) {
        digits[n++] = (char)('0' + (int)(v % 10u));
        digits[n++] = '.';
        v /= 10u;
    }
    do {
        digits[n++] = (char)('0' + (int)(v % 10u));
        v /= 10u;
    } while (v != 0u && n < sizeof digits);
    while (n > 0u) {
        text[len++] = digits[--n];
    }
    text[len] = '\0';
    return len;
}

static void put_padded(const char *text, unsigned len, unsigned width, int right)
{
    unsigned pad = (len < width) ? width - len : 0u;
    if (right) {
        while (pad-- > 0u) {
            put_char(' ');
        }
    }
    m4_out_str(text);
    if (!right) {
        while (pad-- > 0u) {
            put_char(' ');
        }
    }
}

void m4_out_u32(uint32_t v)
{
    m4_out_u32_w(v, 0u);
}

void m4_out_fix16(uint64_t v16)
{
    m4_out_fix16_w(v16, 0u);
}

void m4_out_str_w(const char *s, unsigned width)
{
    unsigned len = 0u;
    while (s[len] != '\0') {
        ++len;
    }
    put_padded(s, len, width, 0);
}

void m4_out_u32_w(uint32_t v, unsigned width)
{
    char text[24];
    put_padded(text, format_decimal(v, 0, text), width, 1);
}

void m4_out_fix16_w(uint64_t v16, unsigned width)
{
    char text[24];
    put_padded(text, format_decimal((v16 * 10u + 8u) / 16u, 1, text), width, 1);
}

void m4_out_hex64(uint64_t v)
{
    put_hex_digits(v, 16u);
}

void m4_out_nl(void)
{
    put_char('\n');
}

int m4_out_flush(void)
{
    flush_buffer();
    return failed ? -1 : 0;
}

uint64_t m4_out_hash(void)
{
    return hash;
}
