// Microbenchmarks of the resources the silhouette kernel (silhouette.cl) spends per
// model-view, for its roofline (mmocap/bench/roofline.py): float32 arithmetic, reads of
// a cache-resident global array, and scattered ORs into a bit mask in local memory. Like the
// silhouette kernel on a CPU, each work-group is one work-item working on vectors, and
// multiplications and additions are not fused.
#pragma OPENCL FP_CONTRACT OFF

// ARITHMETIC: 8 independent chains of x = x * m + c on float16 (the widest vector: one
// register with AVX-512, two with AVX2, and a higher rate than float8 where measured),
// `iterations` times: 2 * 8 * 16 float operations per iteration; the sum of every lane is
// written, so that nothing is optimised away.
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void arithmetic(const int iterations, const float m, const float c, __global float *out)
{
    const float16 start = (float16)(get_global_id(0)) * 1e-6f;
    float16 x0 = start, x1 = start + 1.0f, x2 = start + 2.0f, x3 = start + 3.0f,
           x4 = start + 4.0f, x5 = start + 5.0f, x6 = start + 6.0f, x7 = start + 7.0f;
    for (int i = 0; i < iterations; ++i) {
        x0 = x0 * m + c; x1 = x1 * m + c; x2 = x2 * m + c; x3 = x3 * m + c;
        x4 = x4 * m + c; x5 = x5 * m + c; x6 = x6 * m + c; x7 = x7 * m + c;
    }
    const float16 t = ((x0 + x1) + (x2 + x3)) + ((x4 + x5) + (x6 + x7));
    const float8 s = t.lo + t.hi;
    out[get_global_id(0)] = ((s.s0 + s.s1) + (s.s2 + s.s3)) + ((s.s4 + s.s5) + (s.s6 + s.s7));
}

// READS: every work-group sums the whole array (n8 float8, a multiple of 4), which all of
// them share, as every model-view reads the body's vertex array.
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void reads(__global const float8 *data, const int n8, __global float *out)
{
    float8 s0 = 0.0f, s1 = 0.0f, s2 = 0.0f, s3 = 0.0f;
    for (int i = 0; i < n8; i += 4) {
        s0 += data[i]; s1 += data[i + 1]; s2 += data[i + 2]; s3 += data[i + 3];
    }
    const float8 s = (s0 + s1) + (s2 + s3);
    out[get_global_id(0)] = ((s.s0 + s.s1) + (s.s2 + s.s3)) + ((s.s4 + s.s5) + (s.s6 + s.s7));
}

// SCATTER: every work-group clears `words` (a power of two) words of local memory, then ORs
// one bit into `ors` (a multiple of 32) words at pseudo-random places, as the silhouette
// kernel ORs one bit per kept vertex into a layer. The places come from 32 linear
// congruential sequences in four independent uint8 (one would make the multiplication's
// latency, not the ORs, set the pace). Like the silhouette kernel, each
// vector of bit addresses is stored and its lanes read back one round later, when the store
// has completed; one word is written out.
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void scatter(const int words, const int ors, __local uint *mask, __global uint *out)
{
    for (int k = 0; k < words; ++k) mask[k] = 0u;
    const uint8 seed = (uint8)(1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u) * (2654435761u * (uint)(get_global_id(0) + 1));
    uint8 x0 = seed, x1 = seed + 8u, x2 = seed + 16u, x3 = seed + 24u;
    const uint last_bit = 32u * (uint)words - 1u;
    volatile uint8 pending[4] = {0u, 0u, 0u, 0u};  // bit addresses: bit b % 32 of word b / 32
    for (int i = 0; i < ors; i += 32) {
        x0 = x0 * 1664525u + 1013904223u;
        x1 = x1 * 1664525u + 1013904223u;
        x2 = x2 * 1664525u + 1013904223u;
        x3 = x3 * 1664525u + 1013904223u;
#pragma unroll
        for (int l = 0; l < 32; ++l) {
            const uint b = ((volatile uint *)pending)[l];
            mask[b >> 5] |= 1u << (b & 31u);
        }
        pending[0] = x0 & last_bit;
        pending[1] = x1 & last_bit;
        pending[2] = x2 & last_bit;
        pending[3] = x3 & last_bit;
    }
    out[get_global_id(0)] = mask[(x0.s0 & last_bit) >> 5];
}
