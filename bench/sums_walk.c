/* What bounds rendr's bspln3 value MIP lane sums on the bench's 256^3 view (rays along
 * y, sixteen samples a row apart per batch): a C copy of simd::lanes::sums4_avx512's
 * value path with `ROWS` sharing (the same intrinsics: 128-bit row inserts, the 4 x 4
 * transposes, valignd shifts, then per voxel x*w0, *w1, *w2 and one running sum; no
 * FMA), timed per sample three ways (bench/RESULTS.md run 58):
 *   mode 0: walking a 256^3 float volume as the bench's view does (a strip of 16 rays,
 *           each 15 batches along y), mode 1: the same strip a stretch of ST samples of
 *           every ray at a time, mode 2: the same rows over and over (first-level cache).
 * Build:  gcc -O3 -mavx512f -ffp-contract=off -o sums_walk bench/sums_walk.c
 *         (-DS0=272 pads each 256-float row by 64 bytes)
 * Run:    ./sums_walk MODE [ST]     (HP=1 in the environment: 2 MiB pages) */
#include <immintrin.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <time.h>
#ifndef S0
#define S0 256
#endif
#define S01 (S0 * 256)
static float *vol;

static inline __m512 ld4x4(const float *a, const float *b, const float *c, const float *d) {
    __m512 r = _mm512_castps128_ps512(_mm_loadu_ps(a));
    r = _mm512_insertf32x4(r, _mm_loadu_ps(b), 1);
    r = _mm512_insertf32x4(r, _mm_loadu_ps(c), 2);
    return _mm512_insertf32x4(r, _mm_loadu_ps(d), 3);
}
static inline void lanes_of(const __m512 a[4], __m512 o[4]) {
    __m512 t0 = _mm512_unpacklo_ps(a[0], a[1]), t1 = _mm512_unpackhi_ps(a[0], a[1]);
    __m512 t2 = _mm512_unpacklo_ps(a[2], a[3]), t3 = _mm512_unpackhi_ps(a[2], a[3]);
    o[0] = _mm512_shuffle_ps(t0, t2, 0x44);
    o[1] = _mm512_shuffle_ps(t0, t2, 0xEE);
    o[2] = _mm512_shuffle_ps(t1, t3, 0x44);
    o[3] = _mm512_shuffle_ps(t1, t3, 0xEE);
}
/* One batch: sixteen lanes whose 4^3 supports start a row apart from p. */
__attribute__((noinline)) static __m512 batch(const float *p, const float w[3][4][16]) {
    __m512 val = _mm512_setzero_ps();
#pragma GCC unroll 4
    for (int k = 0; k < 4; k++) {
        __m512 w2 = _mm512_loadu_ps(w[2][k]), r[4], lo[4], hi[4];
        const float *q = p + k * S01;
#pragma GCC unroll 4
        for (int l = 0; l < 4; l++)
            r[l] = ld4x4(q + l * S0, q + (l + 4) * S0, q + (l + 8) * S0, q + (l + 12) * S0);
        lanes_of(r, lo);
#pragma GCC unroll 4
        for (int l = 0; l < 4; l++)
            r[l] = _mm512_broadcast_f32x4(_mm_loadu_ps(q + (16 + (l < 3 ? l : 2)) * S0));
        lanes_of(r, hi);
#pragma GCC unroll 4
        for (int j = 0; j < 4; j++) {
            __m512 w1 = _mm512_loadu_ps(w[1][j]);
#pragma GCC unroll 4
            for (int i = 0; i < 4; i++) {
                __m512i L = _mm512_castps_si512(lo[i]), H = _mm512_castps_si512(hi[i]);
                __m512 x = j == 0   ? lo[i]
                           : j == 1 ? _mm512_castsi512_ps(_mm512_alignr_epi32(H, L, 1))
                           : j == 2 ? _mm512_castsi512_ps(_mm512_alignr_epi32(H, L, 2))
                                    : _mm512_castsi512_ps(_mm512_alignr_epi32(H, L, 3));
                __m512 xw0 = _mm512_mul_ps(x, _mm512_loadu_ps(w[0][i]));
                val = _mm512_add_ps(val, _mm512_mul_ps(_mm512_mul_ps(xw0, w1), w2));
            }
        }
    }
    return val;
}
static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e9 + t.tv_nsec;
}
int main(int argc, char **argv) {
    int mode = argc > 1 ? atoi(argv[1]) : 0, st = argc > 2 ? atoi(argv[2]) : 16;
    static float w[3][4][16];
    size_t n = (size_t)S01 * 260, bytes = (n * 4 + (1 << 21) - 1) & ~(size_t)((1 << 21) - 1);
    vol = aligned_alloc(1 << 21, bytes);
    if (!vol || st < 16) return 1;
    if (getenv("HP")) madvise(vol, bytes, MADV_HUGEPAGE);
    for (size_t i = 0; i < n; i++) vol[i] = (i % 97) * 0.01f;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 4; b++)
            for (int c = 0; c < 16; c++) w[a][b][c] = 0.1f * (b + 1) + c * 0.001f;
    __m512 acc = _mm512_setzero_ps();
    for (int rep = 0; rep < 3; rep++) {
        long nb = 0;
        double t0 = now();
        for (int z = 0; z < 250; z++)
            for (int xs = 0; xs < 240; xs += 16) {
                const float *row = vol + (size_t)z * S01;
                if (mode == 1) {
                    for (int y0 = 0; y0 < 240; y0 += st)
                        for (int x = xs; x < xs + 16; x++)
                            for (int y = y0; y < y0 + st && y < 240; y += 16, nb++)
                                acc = _mm512_add_ps(acc, batch(row + (size_t)y * S0 + x, w));
                } else {
                    for (int x = xs; x < xs + 16; x++)
                        for (int y = 0; y < 240; y += 16, nb++)
                            acc = _mm512_add_ps(
                                acc, batch(mode == 2 ? vol + (x & 3) + (nb & 1)
                                                     : row + (size_t)y * S0 + x, w));
                }
            }
        printf("mode %d S0 %d HP %s: %.2f ns a sample\n", mode, S0, getenv("HP") ? "on" : "off",
               (now() - t0) / nb / 16);
    }
    return _mm512_reduce_add_ps(acc) == 1.2345f;
}
