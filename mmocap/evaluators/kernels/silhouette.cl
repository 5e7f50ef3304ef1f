// The silhouette rule of mmocap/evaluators/silhouette.py: steps 1-2 and the coefficients in
// float64 as view_geometry spells them out, steps 3-6 in float32 as the rule prescribes
// (build with -cl-fp32-correctly-rounded-divide-sqrt); float64 for the per-block culling
// bounds.
// One launch per call: one work-group of LOCAL_SIZE work-items per candidate and group of
// views_per_group cameras (opencl_layout.views_per_group: all of them on CPUs, one on
// GPUs). The work-group first puts its candidate's joint transforms in local memory (with a
// KinematicChain computed there from the joint angles' cosines and sines, once for all its
// views; else the host's), then does its views one after the other in the same local
// memory: the work-items share the view's vertices, stamp their patches into a bit mask
// (1 bit per pixel, rows padded to 32-bit words) and count |M| and |M & F| with popcounts
// against the camera's foreground bit mask, 8 words at a time. Where the largest mask does
// not fit the local memory, each view's rows are split into bands of band_rows rows, one
// work-group per band of its views (stamped directly: a patch clipped to the band's rows
// sets exactly their bits of the whole mask), and the host adds up each view's band counts.
//
// Compile-time constants, every one passed with -D by the host (build_options in
// mmocap/evaluators/opencl_layout.py, their one owner; none is defined here): LOCAL_SIZE,
// LANES, COUNT_WORDS, BLOCK, PAD, MAX_LAYERS, PITCH_WORDS, NEAR_MM, ROUNDING and MAX_SIDE;
// a program is built once per context. With LOCAL_SIZE 1 (CPU devices) a work-group is one
// work-item and plain read-modify-writes replace the local atomics. The counts and, with
// K > 0, the pixels of K model points (project_points) go to one output buffer, read back
// at once; with write_masks != 0 the kernel also copies each view's mask to masks_out
// (nV, mask_words) for rendering. Only mmocap bench's kernel parts (mmocap/bench/parts.py,
// the owner of PARTS and the PART_* numbers) define PARTS = k: the kernel stops after its
// k-th part (layered path) and counts nothing.
#if !defined(LOCAL_SIZE) || !defined(LANES) || !defined(COUNT_WORDS) || !defined(BLOCK)
#error "build with -DLOCAL_SIZE, -DLANES, -DCOUNT_WORDS and -DBLOCK (opencl_layout.build_options)"
#endif
#if !defined(PAD) || !defined(MAX_LAYERS) || !defined(PITCH_WORDS)
#error "build with -DPAD, -DMAX_LAYERS and -DPITCH_WORDS (opencl_layout.build_options)"
#endif
#if !defined(NEAR_MM) || !defined(ROUNDING) || !defined(MAX_SIDE)
#error "build with -DNEAR_MM, -DROUNDING and -DMAX_SIDE (opencl_layout.build_options)"
#endif
// Kernel parts: KEPT(part), whether the kernel runs that part; STOPS_AFTER(part), whether it
// is the last it runs (always 1 and 0 unless PARTS is defined).
#ifdef PARTS
#define KEPT(part) (PARTS >= (part))
#define STOPS_AFTER(part) (PARTS == (part))
#else
#define KEPT(part) 1
#define STOPS_AFTER(part) 0
#endif
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF   // no fused multiply-adds: round as NumPy does

#if LOCAL_SIZE == 1
#define OR_WORD(p, x) (*(p) |= (x))
#define MIN_INT(p, x) (*(p) = MIN(*(p), (x)))
#define MAX_INT(p, x) (*(p) = MAX(*(p), (x)))
#define ADD_INT(p, x) (*(p) += (x))
#else
#define OR_WORD(p, x) atomic_or((p), (x))
#define MIN_INT(p, x) atomic_min((p), (x))
#define MAX_INT(p, x) atomic_max((p), (x))
#define ADD_INT(p, x) atomic_add((p), (x))
#endif

// Each joint's vertices come in blocks of BLOCK, each with a cone holding its normals and a
// sphere holding its positions (see culling_cones in opencl_layout.py): a block that is certainly
// all back faces is skipped with one test, one certainly all facing the camera skips the
// per-vertex culling test; the others are culled vertex by vertex.

// Vertices are processed LANES (4, 8 or 16, dividing BLOCK) at a time in vectors of that
// width (on CPUs one vector register: 16 floats with AVX-512, 8 with AVX2). The vertex array
// holds per vector its seven rows of LANES floats side by side (interleaved in
// opencl_layout.py); each joint's run is padded to a multiple of BLOCK with zero-normal
// vertices, which the culling test always rejects.
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define floatV CAT(float, LANES)
#define intV CAT(int, LANES)
#define uintV CAT(uint, LANES)
// Vector conversions use Clang's __builtin_convertvector where the compiler has it: the same
// fptosi, sitofp, zext and trunc as PoCL's convert_* functions, but in place. PoCL 3.0
// (pocl-binary-distribution 3.0, LLVM 14) calls convert_* in its kernel library, chosen by
// the CPU's features (the AVX-512 variant, built for skylake-avx512, wherever AVX-512F is
// there), and compiles this kernel for the CPU that LLVM 14 names: an AMD Zen 4 (EPYC,
// family 25 model 17) is "znver3" to it, without AVX-512, so 512-bit vectors (ulong8, and
// float16 and int16 at LANES 16) crossed between the two in other registers than expected:
// every count 0 at LANES 4 and 8, LLVM out of memory at LANES 16. PoCL 3.0 has no setting
// for its target CPU, and its build options take no -target-cpu or -target-feature.
#ifdef __has_builtin
#if __has_builtin(__builtin_convertvector)
#define CONVERT(x, type) __builtin_convertvector((x), type)
#endif
#endif
#ifndef CONVERT
#define CONVERT(x, type) CAT(convert_, type)(x)
#endif
#define convert_intV(x) CONVERT(x, intV)
#define convert_uintV(x) CONVERT(x, uintV)
#define convert_floatV(x) CONVERT(x, floatV)
#define as_uintV CAT(as_uint, LANES)
#define as_intV CAT(as_int, LANES)
// CPUs with SSE4.1 (or AVX) round a float vector down in one instruction: Clang's
// elementwise floor gives it in place (PoCL calls OpenCL's floor as a function, and
// Oclgrind, compiling for SPIR, has no llvm.floor of vectors).
#if defined(__SSE4_1__) && defined(__has_builtin)
#if __has_builtin(__builtin_elementwise_floor)
#define FLOOR_INSTRUCTION
#endif
#endif

// PoCL (3.0) calls builtins such as vload, vstore, any, min, max, clamp and popcount as
// functions instead of inlining them, so the loops below use plain operators instead. MIN
// and MAX work on scalars and vectors.
#define MIN(a, b) ((a) < (b) ? (a) : (b))
#define MAX(a, b) ((a) > (b) ? (a) : (b))
#if LANES == 16
#define LANE_INDEX ((int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#elif LANES == 8
#define LANE_INDEX ((int8)(0, 1, 2, 3, 4, 5, 6, 7))
#else
#define LANE_INDEX ((int4)(0, 1, 2, 3))
#endif
// LANES floats at p, an offset into a vertex array that is a multiple of LANES
#define LOAD(p) (*(__global const floatV *)(p))
// lane i of a private vector v whose lanes have the given type
#define LANE(type, v, i) (((const type *)&(v))[i])

// Views whose joints have at most max_layers distinct patch sides, all <= 32 (the usual
// case), take the layered path: each vertex sets one bit, at its centre, in the layer of its
// joint's side, padded by PAD px on every side (a centre further out cannot reach the
// image); counting then dilates each layer by its s x s patch with shifts and ORs on 64-bit
// windows and ORs the layers, COUNT_WORDS (8 on CPUs, else 1) output words at a time.
// Other views stamp every patch.

// Rows of the masks and of the foreground are PITCH_WORDS-aligned: pitch = stride rounded up
// to a multiple of 8 words; the padded layers' rows (pstride words) hold the image's stride
// words and one more, rounded up to a multiple of COUNT_WORDS.
#if COUNT_WORDS == 8
#define uintW uint8
#define ulongW ulong8
#define intW int8
#define convert_ulongW(x) CONVERT(x, ulong8)
#define convert_uintW(x) CONVERT(x, uint8)
#define bit_count_uintW bit_count_uint8
// words w + 1 .. w + 8 from words w .. w + 7 (here) and word w + 8 (next)
#define NEXT_WORDS(here, next) ((uint8)((here).s1234, (here).s567, (next)))
#define WORD_INDEX ((int8)(0, 1, 2, 3, 4, 5, 6, 7))
#define SUM_WORDS(v) ((v).s0 + (v).s1 + (v).s2 + (v).s3 + (v).s4 + (v).s5 + (v).s6 + (v).s7)
#else
#define uintW uint
#define ulongW ulong
#define intW int
#define convert_ulongW convert_ulong
#define convert_uintW convert_uint
#define bit_count_uintW bit_count_uint
#define NEXT_WORDS(here, next) (next)
#define WORD_INDEX 0
#define SUM_WORDS(v) (v)
#endif

// (cx, cy) clamped to [-2^20, 2^20] before the conversion to int: far beyond any image.
#define CLAMP_PX 1048576.0f

// floor(t) as int for t within int's range (no NaN: converting a float out of it to int
// is undefined); exact.
inline intV floor_in_range(const floatV t)
{
#ifdef FLOOR_INSTRUCTION
    return convert_intV(__builtin_elementwise_floor(t));
#else
    const intV truncated = convert_intV(t);
    return truncated + (convert_floatV(truncated) > t);   // true is -1
#endif
}

// floor(t) as int, t clamped to [-CLAMP_PX, CLAMP_PX] (NaN, from a rejected vertex, to 0);
// exact, and on PoCL faster than the floor, clamp and convert builtins together.
inline intV floor_int(floatV t)
{
    t = t != t ? (floatV)(0.0f) : t;
    t = t < -CLAMP_PX ? -CLAMP_PX : t;
    t = t > CLAMP_PX ? CLAMP_PX : t;
    return floor_in_range(t);
}

// Whether any lane of a comparison result is true (-1).
inline int any_lane(const intV m)
{
#if LANES == 16
    const int8 m8 = m.lo | m.hi;
    const int4 m4 = m8.lo | m8.hi;
#elif LANES == 8
    const int4 m4 = m.lo | m.hi;
#else
    const int4 m4 = m;
#endif
    const int2 m2 = m4.lo | m4.hi;
    return (m2.x | m2.y) != 0;
}

// The smallest and the largest lane.
inline int min_lane(const intV x)
{
    int m = LANE(int, x, 0);
    for (int i = 1; i < LANES; ++i) m = MIN(m, LANE(int, x, i));
    return m;
}

inline int max_lane(const intV x)
{
    return -min_lane(-x);
}

// Sets the bits of the patch of one kept vertex; widens the row range [*lo, *hi] it touched.
// A clipped patch row of at most 32 pixels spans words w0 and w0 + 1 (the latter maybe
// with no bit to set: the mask has a spare word at its end for that).
// Inlined, as are the steps of silhouette_counts: a call in the vertex loop would make every
// vector it keeps in registers live on the stack instead (all vector registers are
// caller-saved).
__attribute__((always_inline)) inline void stamp(__local uint *mask, const int stride,
                                                 const int width, const int height,
                                                 const int cx, const int cy, const int before,
                                                 const int after, int *lo, int *hi)
{
    const int col0 = MAX(cx - before, 0), col1 = MIN(cx + after, width - 1);
    const int row0 = MAX(cy - before, 0), row1 = MIN(cy + after, height - 1);
    if (col0 > col1 || row0 > row1) return;
    *lo = MIN(*lo, row0);
    *hi = MAX(*hi, row1);
    const int w0 = col0 >> 5, len = col1 - col0 + 1;
    if (len <= 32) {
        const ulong bits = (0xffffffffUL >> (32 - len)) << (col0 & 31);
        const uint low = (uint)bits, high = (uint)(bits >> 32);
        for (__local uint *row = mask + row0 * stride + w0; row <= mask + row1 * stride + w0;
             row += stride) {
            OR_WORD(row, low);
            OR_WORD(row + 1, high);
        }
        return;
    }
    const int w1 = col1 >> 5;
    const uint first = 0xffffffffu << (col0 & 31);
    const uint last = 0xffffffffu >> (31 - (col1 & 31));
    for (int r = row0; r <= row1; ++r) {
        __local uint *row = mask + r * stride;
        OR_WORD(row + w0, first);
        for (int k = w0 + 1; k < w1; ++k) OR_WORD(row + k, 0xffffffffu);
        OR_WORD(row + w1, last);
    }
}

// Sets bit b % 32 of words[b / 32] for the bit address b in each lane of *pending, lane by
// lane (unrolled).
__attribute__((always_inline)) inline void set_bits(__local uint *words,
                                                   volatile const intV *pending)
{
#pragma unroll
    for (int i = 0; i < LANES; ++i) {
        const int bit = ((volatile const int *)pending)[i];
        OR_WORD(words + (bit >> 5), 1u << (bit & 31));
    }
}

// Set bits per 32-bit lane (SWAR), for uint and for 8 lanes at once.
#define BIT_COUNT(type)                                                   \
    inline type bit_count_##type(type v)                                  \
    {                                                                     \
        v = v - ((v >> 1) & 0x55555555u);                                 \
        v = (v & 0x33333333u) + ((v >> 2) & 0x33333333u);                 \
        v = (v + (v >> 4)) & 0x0f0f0f0fu;                                 \
        return (v * 0x01010101u) >> 24;                                   \
    }
BIT_COUNT(uint)
BIT_COUNT(uint8)

// Steps 3-4 for the LANES vertices from v (coefficients a, b of view_geometry): whether each
// is kept, and u + 0.5, v + 0.5 (the centre pixel is their floor); 0 when none faces the
// camera. all_facing skips the culling test (see the block tests below).
inline int project_lanes(__global const float *vertices, const int v, const int all_facing,
                         const float *a, const float *b, intV *keep, floatV *tu, floatV *tw)
{
    __global const float *row = vertices + 7 * v;  // x, y, z, nx, ny, nz, n . v of each lane
    // culling first: n' . p = n . v + n . (R^T t); all back faces: nothing else to do
    intV facing = (intV)(-1);
    if (!all_facing) {
        const floatV nx = LOAD(row + 3 * LANES), ny = LOAD(row + 4 * LANES),
                     nz = LOAD(row + 5 * LANES), nv = LOAD(row + 6 * LANES);
        facing = nv + (nx * b[0] + ny * b[1] + nz * b[2]) < 0.0f;
        if (!any_lane(facing)) return 0;
    }
#if STOPS_AFTER(PART_CULLING)
    *keep = facing;
    return 1;
#endif
    const floatV x = LOAD(row), y = LOAD(row + LANES), z = LOAD(row + 2 * LANES);
    const floatV pz = a[8] * x + a[9] * y + a[10] * z + a[11];
    *keep = facing & (pz > (float)NEAR_MM);  // lanes off: masked by the caller
    const floatV inv = 1.0f / pz;
    *tu = (a[0] * x + a[1] * y + a[2] * z + a[3]) * inv + 0.5f;
    *tw = (a[4] * x + a[5] * y + a[6] * z + a[7]) * inv + 0.5f;
    return 1;
}

// Steps 1-2 for one view and joint, in float64 as silhouette.view_geometry: entry (i, k) of
// A = P [R t] from row i of the camera's P (4 values) and the joint's T = [R t] (3x4,
// row-major), for k < 3 and for k = 3.
inline double a_rotation(__global const double *P_i, __local const double *T, const int k)
{
    return (P_i[0] * T[k] + P_i[1] * T[4 + k]) + P_i[2] * T[8 + k];
}

inline double a_translation(__global const double *P_i, __local const double *T)
{
    return ((P_i[0] * T[3] + P_i[1] * T[7]) + P_i[2] * T[11]) + P_i[3];
}

// The patch side in px of a joint (rest position and patch mm in joint[0..3]), 0 if dropped.
inline int patch_side(__global const double *camera, __local const double *T,
                      __global const double *joint)
{
    __global const double *P2 = camera + 8;
    const double z = ((a_rotation(P2, T, 0) * joint[0] + a_rotation(P2, T, 1) * joint[1])
                      + a_rotation(P2, T, 2) * joint[2]) + a_translation(P2, T);
    if (!(z > NEAR_MM)) return 0;
    const double s = ceil((camera[15] * joint[3]) / z);
    return s < 1.0 ? 1 : s > MAX_SIDE ? MAX_SIDE : (int)s;
}

// A candidate's joint transforms S_j = [R t] (J, 12: 3x4, row-major, mm) into local memory,
// where every view of its work-group reads them. With a KinematicChain
// (mmocap/body/kinematics.py) work-item 0 computes them from the pose rows in the chain's
// float64 order: the global transforms G_j first (joints come after their parents, which
// they read), then each turned into S_j = G_j translate(-o_j) in place; the same bits as
// KinematicChain's. Without one the work-items copy the host's (body.transforms). A barrier
// must follow.
__attribute__((always_inline)) inline void candidate_transforms(
    __global const double *pose,       // with_chain: (3 + 6 J,) KinematicChain.pose_rows:
                                       // T (mm), then per joint cos a, cos b, cos c, sin a,
                                       // sin b, sin c; else (J, 12) the transforms
    __global const double *chain,      // (J, 16) KinematicChain.rows: A (3x3, row-major),
                                       // o_j - o_parent (mm), o_j (mm), parent (-1: root)
    const int with_chain, const int J, const int lid, __local double *out)
{
    if (!with_chain) {
        for (int k = lid; k < 12 * J; k += LOCAL_SIZE) out[k] = pose[k];
        return;
    }
    if (lid != 0) return;
    for (int j = 0; j < J; ++j) {  // G_j
        __global const double *A = chain + 16 * j, *q = pose + 3 + 6 * j;
        const double ca = q[0], cb = q[1], cc = q[2], sa = q[3], sb = q[4], sc = q[5];
        const double R[9] = {cb * cc, -cb * sc, sb,
                             ca * sc + sa * sb * cc, ca * cc - sa * sb * sc, -sa * cb,
                             sa * sc - ca * sb * cc, sa * cc + ca * sb * sc, ca * cb};
        double M[9], L[9];  // M = R A^T, L = A M
        for (int a = 0; a < 3; ++a)
            for (int k = 0; k < 3; ++k)
                M[3 * a + k] = (R[3 * a] * A[3 * k] + R[3 * a + 1] * A[3 * k + 1])
                               + R[3 * a + 2] * A[3 * k + 2];
        for (int a = 0; a < 3; ++a)
            for (int k = 0; k < 3; ++k)
                L[3 * a + k] = (A[3 * a] * M[k] + A[3 * a + 1] * M[3 + k])
                               + A[3 * a + 2] * M[6 + k];
        const int parent = (int)A[15];
        __local double *g = out + 12 * j;
        if (parent < 0) {
            for (int a = 0; a < 3; ++a) {
                for (int k = 0; k < 3; ++k) g[4 * a + k] = L[3 * a + k];
                g[4 * a + 3] = pose[a];
            }
        } else {
            __local const double *P = out + 12 * parent;
            for (int a = 0; a < 3; ++a) {
                for (int k = 0; k < 3; ++k)
                    g[4 * a + k] = (P[4 * a] * L[k] + P[4 * a + 1] * L[3 + k])
                                   + P[4 * a + 2] * L[6 + k];
                g[4 * a + 3] = ((P[4 * a] * A[9] + P[4 * a + 1] * A[10]) + P[4 * a + 2] * A[11])
                               + P[4 * a + 3];
            }
        }
    }
    for (int j = 0; j < J; ++j) {  // S_j = G_j translate(-o_j)
        __global const double *A = chain + 16 * j;
        __local double *g = out + 12 * j;
        for (int a = 0; a < 3; ++a)
            g[4 * a + 3] = g[4 * a + 3] - ((g[4 * a] * A[12] + g[4 * a + 1] * A[13])
                                          + g[4 * a + 2] * A[14]);
    }
}

// The steps of silhouette_counts, in the order it runs them for one model-view.

// What a view's work-items gather in local memory: the rows (padded rows when layered) and
// the padded columns (layered only) that their stamps or centres reached, and the counts.
typedef struct {
    int row_lo, row_hi, col_lo, col_hi, model_px, overlap_px;
} ViewTotals;

// What one work-item's stamps or centres reached: rows (padded rows when layered) from
// stamp(), and per lane the rows of the stamps or the image rows and columns of the layered
// path's centres (PAD less than the padded ones).
typedef struct {
    int lo, hi;
    intV loV, hiV, leftV, rightV;
} Reach;

// Setup: the distinct patch sides of the view's J joints, one per layer, in side_of[0 ..
// *layers - 1]; whether the view takes the layered path (at most max_layers sides, all <=
// 32); the mask cleared (its layers, or the mask and its spare word) and the totals reset.
// A barrier must follow.
__attribute__((always_inline)) inline int setup_view(
    __global const double *camera, __local const double *T0, __global const double *joints,
    const int J, const int max_layers, const int width, const int height, const int pitch,
    const int layer_words, const int lid, __local uint8 *mask, __local ViewTotals *totals,
    int *side_of, int *layers)
{
    int layered = max_layers > 0;
    *layers = 0;
    for (int j = 0; j < J; ++j) {
        const int s = patch_side(camera, T0 + 12 * j, joints + 4 * j);
        int l = 0;
        while (l < *layers && side_of[l] != s) ++l;
        if (s == 0 || l < *layers) continue;
        if (s > 32 || *layers == max_layers) layered = 0;
        else side_of[(*layers)++] = s;
    }
    const int used = layered ? *layers * layer_words : pitch * height + 1;
    for (int k = lid; k < (used + 7) / 8; k += LOCAL_SIZE) mask[k] = (uint8)(0u);
    if (lid == 0) {
        totals->row_lo = height + 2 * PAD; totals->row_hi = -1;
        totals->col_lo = width + 2 * PAD; totals->col_hi = -1;
        totals->model_px = 0; totals->overlap_px = 0;
    }
    return layered;
}

// Steps 1-2's projection coefficients for one view and joint, rounded to float32 once:
// a = A (3x4, row-major).
__attribute__((always_inline)) inline void joint_projection(__global const double *camera,
                                                           __local const double *T, float *a)
{
    for (int i = 0; i < 3; ++i) {
        for (int k = 0; k < 3; ++k) a[4 * i + k] = a_rotation(camera + 4 * i, T, k);
        a[4 * i + 3] = a_translation(camera + 4 * i, T);
    }
}

// Steps 1-2's coefficients for one view and joint, rounded to float32 once: a = A (3x4,
// row-major) and b = R^T (t - centre).
__attribute__((always_inline)) inline void joint_coefficients(__global const double *camera,
                                                             __local const double *T,
                                                             float *a, float *b)
{
    joint_projection(camera, T, a);
    const double d0 = T[3] - camera[12], d1 = T[7] - camera[13], d2 = T[11] - camera[14];
    b[0] = (T[0] * d0 + T[4] * d1) + T[8] * d2;
    b[1] = (T[1] * d0 + T[5] * d1) + T[9] * d2;
    b[2] = (T[2] * d0 + T[6] * d1) + T[10] * d2;
}

// Whether the culling block with this cone may hold a vertex facing the camera (b of
// joint_coefficients); *all_facing: every one of its vertices certainly faces it.
__attribute__((always_inline)) inline int block_may_face(__global const double *cone,
                                                         const float *b, int *all_facing)
{
    // the whole block behind its normals: n . (v + b) >= (a . d) cos - |a x d| sin - r > 0
    const double dx = cone[5] + b[0], dy = cone[6] + b[1], dz = cone[7] + b[2];
    const double ad = cone[0] * dx + cone[1] * dy + cone[2] * dz;
    const double dd = dx * dx + dy * dy + dz * dz;
    const double cross = sqrt(MAX(dd - ad * ad, 0.0)), dlen = sqrt(dd);
    // r also bounds the float32 rounding of the per-vertex test (see culling_cones)
    const double r = cone[8] + ROUNDING * dlen;
    if (ad * cone[3] - cross * cone[4] > r) return 0;
    // the whole block, padding-free, facing: n . (v + b) <= max over the cone of n . d + r < 0
    const double upper = ad <= dlen * cone[3] ? ad * cone[3] + cross * cone[4] : dlen;
    *all_facing = cone[9] != 0.0 && upper + r < 0.0;
    return 1;
}

// Whether the culling block with this cone may stamp a patch (side s) into image rows
// row_lo .. row_hi (a band), for A = a of joint_coefficients: the image row of a point of
// its sphere (centre c, radius r) is N / D for N = A[1] . (x, 1) and D = A[2] . (x, 1),
// within N(c) +- r |A[1]'s first 3| and D(c) +- r |A[2]'s first 3|, so between the smallest
// and the largest of the four quotients of those bounds where D's lower bound is past the
// near plane (else 1: no bound). The margin holds the float32 rounding of the kernel's u, v:
// a few units in the last place of the terms' magnitudes over the depth, here far more.
__attribute__((always_inline)) inline int block_meets_rows(__global const double *cone,
                                                           const float *a, const int s,
                                                           const int row_lo, const int row_hi)
{
    const double r = cone[8], x = cone[5], y = cone[6], z = cone[7];
    if (!(r < INFINITY)) return 1;  // a block with normals over a half space: r = inf
    const double a4 = a[4], a5 = a[5], a6 = a[6], a8 = a[8], a9 = a[9], a10 = a[10];
    const double num = ((a4 * x + a5 * y) + a6 * z) + a[7];
    const double den = ((a8 * x + a9 * y) + a10 * z) + a[11];
    const double num_r = r * sqrt(a4 * a4 + a5 * a5 + a6 * a6);
    const double den_r = r * sqrt(a8 * a8 + a9 * a9 + a10 * a10);
    const double near = den - den_r, far = den + den_r;
    if (!(near > NEAR_MM)) return 1;
    const double low = num - num_r, high = num + num_r;
    const double v_lo = MIN(low / near, low / far), v_hi = MAX(high / near, high / far);
    const double ax = fabs(x) + r, ay = fabs(y) + r, az = fabs(z) + r;
    const double num_size = fabs(a4) * ax + fabs(a5) * ay + fabs(a6) * az + fabs((double)a[7]);
    const double den_size = fabs(a8) * ax + fabs(a9) * ay + fabs(a10) * az + fabs((double)a[11]);
    const double margin = 2.0 + 1e-5 * (num_size + MAX(fabs(v_lo), fabs(v_hi)) * den_size) / near;
    // centre rows floor(v + 0.5), patch rows from centre - (s - 1) / 2 to centre + s / 2
    return v_hi + 0.5 + margin + s / 2 >= row_lo && v_lo + 0.5 - margin - (s - 1) / 2 <= row_hi + 1;
}

// Layered scatter of culling block blk: each kept vertex whose centre lies in the padded
// layer sets one bit, at its centre, in the layer whose image pixel (0, 0) has bit address
// origin (PAD rows and columns into the layer); reach's lanes get the centres' image rows
// and columns. The bit addresses of the last vector of centres wait in
// *pending (a lane without a centre: its own sink word past the layers, see SINK_WORDS) and
// are set one vector later: read back from memory lane by lane (faster than extracting them
// from registers) once their store has long completed (read right after it, every load
// would wait for the store).
__attribute__((always_inline)) inline void scatter_centres(
    __global const float *vertices, const int blk, const int all_facing, const float *a,
    const float *b, const int width, const int height, const int pstride, const int origin,
    const intV sink, __local uint *words, volatile intV *pending, Reach *reach)
{
    for (int v = BLOCK * blk; v < BLOCK * (blk + 1); v += LANES) {
        intV keep;
        floatV tu, tw;
        if (!project_lanes(vertices, v, all_facing, a, b, &keep, &tu, &tw)) continue;
#if STOPS_AFTER(PART_CULLING)  // the parts' results kept alive, cheaply
        reach->hiV = MAX(reach->hiV, keep);
        continue;
#elif STOPS_AFTER(PART_PROJECTION)
        reach->hiV = MAX(reach->hiV, keep & (as_intV(tu) ^ as_intV(tw)));
        continue;
#endif
        // a centre in the padded layer: in range as a float, so floor needs no clamp
        const intV in = keep & (tu >= (float)-PAD) & (tu < (float)(width + PAD))
                        & (tw >= (float)-PAD) & (tw < (float)(height + PAD));
        // lanes that are not in take the floor of width + PAD and height + PAD, past every
        // centre (so the lower bounds need no select): a float out of int's range (or NaN)
        // converts to an undefined value, which may spoil the masked results too
        const intV px = floor_in_range(in ? tu : (floatV)(width + PAD));
        const intV py = floor_in_range(in ? tw : (floatV)(height + PAD));
        reach->loV = MIN(reach->loV, py);
        reach->hiV = MAX(reach->hiV, in ? py : reach->hiV);
        reach->leftV = MIN(reach->leftV, px);
        reach->rightV = MAX(reach->rightV, in ? px : reach->rightV);
#if KEPT(PART_ORS)
        set_bits(words, pending);
#endif
        *pending = in ? origin + py * (32 * pstride) + px : sink;
    }
}

// Direct stamp of culling block blk: each kept vertex sets the bits of its s x s patch in
// the mask (rows of pitch words) that holds image rows band_lo .. band_lo + height - 1,
// clipped to them; reach gets the rows (of the band) they touched.
__attribute__((always_inline)) inline void stamp_patches(
    __global const float *vertices, const int blk, const int all_facing, const float *a,
    const float *b, const int width, const int height, const int pitch, const int s,
    const int band_lo, __local uint *words, Reach *reach)
{
    const int before = (s - 1) / 2, after = s / 2;
    for (int v = BLOCK * blk; v < BLOCK * (blk + 1); v += LANES) {
        intV keep;
        floatV tu, tw;
        if (!project_lanes(vertices, v, all_facing, a, b, &keep, &tu, &tw)) continue;
        // rows relative to the band's first (|floor| <= CLAMP_PX: no overflow)
        const intV cx = floor_int(tu), cy = floor_int(tw) - band_lo;
        if (s > 32) {  // large patches (a body part close to the camera): one by one
            for (int i = 0; i < LANES; ++i)
                if (LANE(int, keep, i))
                    stamp(words, pitch, width, height, LANE(int, cx, i), LANE(int, cy, i),
                          before, after, &reach->lo, &reach->hi);
            continue;
        }
        // all lanes at once: clipping in intV, no branch per vertex; a rejected or
        // clipped-away vertex gets an empty range of words [first, last]
        const intV col0 = MAX(cx - before, 0), col1 = MIN(cx + after, width - 1);
        const intV row0 = MAX(cy - before, 0), row1 = MIN(cy + after, height - 1);
        const intV ok = keep & (col0 <= col1) & (row0 <= row1);
        reach->loV = MIN(reach->loV, ok ? row0 : height);
        reach->hiV = MAX(reach->hiV, ok ? row1 : -1);
        // 1 + MAX(.., 0) rather than MAX(.. + 1, 1): clang compiles MAX(x, 1) on vectors
        // to select(x > 1, x, 0) | zext(!(x > 1)), and on Oclgrind, whose vector compares
        // give all-ones lanes but whose constant true is 1, that zext is 254 where x > 1
        // (every len 32)
        const uintV len = convert_uintV(MIN(MAX(col1 - col0, 0) + 1, 32));
        const uintV shift = convert_uintV(col0) & 31u;
        const uintV low = ((uintV)(0xffffffffu) >> (32u - len)) << shift;
        // bits of the patch past word w0: (ones(len) << shift) >> 32, 0 when shift 0
        const uintV high = shift == 0u ? 0u : ((uintV)(0xffffffffu) >> (32u - len)) >> (32u - shift);
        const intV first = ok ? row0 * pitch + (col0 >> 5) : 0;
        const intV last = ok ? row1 * pitch + (col0 >> 5) : -1;
        for (int i = 0; i < LANES; ++i)
            for (int k = LANE(int, first, i); k <= LANE(int, last, i); k += pitch) {
                OR_WORD(words + k, LANE(uint, low, i));
                OR_WORD(words + k + 1, LANE(uint, high, i));
            }
    }
}

// Dilate-and-count (layered path): dilates each layer by its s x s patch with shifts and
// ORs on 64-bit windows, ORs the layers and counts |M| and |M & F| (f: the camera's
// foreground) over this work-item's share of the rows the totals reached, COUNT_WORDS
// output words at a time; with write_masks it also writes M to out (pitch words a row).
__attribute__((always_inline)) inline void dilate_and_count(
    __local const uint *words, const int *side_of, const int layers, const int layer_words,
    const int pstride, const int stride, const int pitch, const int width, const int height,
    __local const ViewTotals *totals, __global const uint *f, const int lid,
    const int write_masks, __global uint *out, int *model, int *overlap)
{
    int before = 0, after = 0;  // the largest reach of the layers' patches
    for (int l = 0; l < layers; ++l) {
        before = MAX(before, (side_of[l] - 1) / 2);
        after = MAX(after, side_of[l] / 2);
    }
    const int r0 = MAX(totals->row_lo - PAD - before, 0);
    const int r1 = MIN(totals->row_hi - PAD + after, height - 1);
    const uint edge = (width & 31) ? 0xffffffffu >> (32 - (width & 31)) : 0xffffffffu;
    if (write_masks) {
        for (int k = lid; k < pitch * height; k += LOCAL_SIZE) out[k] = 0u;
        barrier(CLK_GLOBAL_MEM_FENCE);
    }
    // output words w0 .. w1, in groups of COUNT_WORDS from a multiple of it
    const int w0 = (MAX(totals->col_lo - PAD - before, 0) >> 5) / COUNT_WORDS * COUNT_WORDS;
    const int w1 = MIN(totals->col_hi - PAD + after, width - 1) >> 5;
    uintW model_w = 0u, overlap_w = 0u;
    for (int r = r0 + lid; r <= r1; r += LOCAL_SIZE)
    for (int w = w0; w <= w1; w += COUNT_WORDS) {
        ulongW bits = 0;
        for (int l = 0; l < layers; ++l) {
            // output row r: padded rows r + shift .. r + shift + side - 1 of the layer (the
            // centres whose patch rows reach r); bit j of acc: centre column 32 w + j - after
            const int side = side_of[l], shift = PAD - side / 2;
            __local const uint *base = words + l * layer_words + (r + shift) * pstride + w;
            uintW here = 0u;  // words w .. w + COUNT_WORDS - 1 of the rows, ORed
            uint next = 0u;   // word w + COUNT_WORDS (within the row: see pstride)
            for (int t = 0; t < side; ++t) {
                here |= *(__local const uintW *)(base + t * pstride);
                next |= base[t * pstride + COUNT_WORDS];
            }
            ulongW acc = (convert_ulongW(here) | (convert_ulongW(NEXT_WORDS(here, next)) << 32))
                         >> shift;
            // output bit i: any of bits i .. i + side - 1 of acc
            int cover = 1;
            for (; 2 * cover <= side; cover *= 2) acc |= acc >> cover;
            acc |= acc >> (side - cover);
            bits |= acc;
        }
        const intW word = w + WORD_INDEX;  // words past the row's last hold no pixel
        const uintW m = convert_uintW(bits)
                        & (word < stride - 1 ? 0xffffffffu : word == stride - 1 ? edge : 0u);
        model_w += bit_count_uintW(m);
        overlap_w += bit_count_uintW(m & *(__global const uintW *)(f + r * pitch + w));
        if (write_masks)
            for (int i = 0; i < COUNT_WORDS && w + i < stride; ++i)
                out[r * pitch + w + i] = LANE(uint, m, i);
    }
    *model = SUM_WORDS(model_w);
    *overlap = SUM_WORDS(overlap_w);
}

// Count (direct path): |M| and |M & F| (f: the camera's foreground) over this work-item's
// share of the stamped mask's rows row_lo .. row_hi, 8 words at a time.
__attribute__((always_inline)) inline void count_stamped(
    __local const uint8 *mask, __global const uint8 *f, const int row_lo, const int row_hi,
    const int pitch, const int lid, int *model, int *overlap)
{
    uint8 model8 = 0u, overlap8 = 0u;
    for (int k = row_lo * pitch / 8 + lid; k < (row_hi + 1) * pitch / 8; k += LOCAL_SIZE) {
        const uint8 bits = mask[k];
        model8 += bit_count_uint8(bits);
        overlap8 += bit_count_uint8(bits & f[k]);
    }
    *model = model8.s0 + model8.s1 + model8.s2 + model8.s3 + model8.s4 + model8.s5
             + model8.s6 + model8.s7;
    *overlap = overlap8.s0 + overlap8.s1 + overlap8.s2 + overlap8.s3 + overlap8.s4
               + overlap8.s5 + overlap8.s6 + overlap8.s7;
}

// The pixels of the model points (keypoint_pixels in silhouette.py) in one view, the
// work-items sharing the points: u, v of each point from its joint's A in the rule's float32
// arithmetic, NaN for both where depth <= NEAR_MM. 1 / depth is taken in float64 and
// rounded to float32: that is the correctly rounded float32 quotient (float64 division is
// correctly rounded, and with 53 >= 2 * 24 + 2 bits rounding twice gives the same float32)
// on every device, whether or not it honours -cl-fp32-correctly-rounded-divide-sqrt, which
// the vertices' floored centres hardly notice and these pixels would. The NaN is NumPy's
// (0x7fc00000), not the device's NAN (0x7fffffff on PoCL), so that the bits agree too.
#define NUMPY_NAN as_float(0x7fc00000u)
__attribute__((always_inline)) inline void project_points(
    __global const double *camera, __local const double *T0, const int K,
    __global const int *point_joint, __global const float *point_rest, const int lid,
    __global float *out)
{
    for (int k = lid; k < K; k += LOCAL_SIZE) {
        float a[12];
        joint_projection(camera, T0 + 12 * point_joint[k], a);
        const float x = point_rest[3 * k], y = point_rest[3 * k + 1], z = point_rest[3 * k + 2];
        const float depth = a[8] * x + a[9] * y + a[10] * z + a[11];
        const float r = (float)(1.0 / (double)depth);
        const int seen = depth > (float)NEAR_MM;
        out[2 * k] = seen ? (a[0] * x + a[1] * y + a[2] * z + a[3]) * r : NUMPY_NAN;
        out[2 * k + 1] = seen ? (a[4] * x + a[5] * y + a[6] * z + a[7]) * r : NUMPY_NAN;
    }
}

// What a work-group's views share: the arrays of the body, the frame and the call, the local
// memory, and the layout of the output.
typedef struct {
    __global const float *vertices;
    __global const int *joint_start;
    __global const double *cones, *cameras, *joints;
    __global const int *shapes;
    __global const uint *fg;
    int J, max_layers, bands, band_rows, write_masks, mask_words, K;
    __global uint *masks_out;
    __global const int *point_joint;
    __global const float *point_rest;
    __global int *counts;
    __global float *pixels;
} Frame;

// One model-view g = candidate * C + c and band of it, by the work-group: its model points'
// pixels (by the first band), its mask set up, stamped or scattered and dilated, and counted
// into counts[g * bands + band]. T0: the candidate's transforms in local memory. Every
// work-item of the group calls it with the same view (it has barriers); a barrier must
// follow before the local memory is used again.
__attribute__((always_inline)) inline void count_view(
    const Frame *fr, const int g, const int c, const int band, __local const double *T0,
    __local uint8 *mask, __local ViewTotals *totals, const int lid)
{
    // a band holds image rows band_lo .. band_lo + height - 1 of the mask, stamped directly
    // (patches clipped to them: no halo), and counts them against the same rows of the
    // foreground
    const int J = fr->J, max_layers = fr->max_layers, bands = fr->bands, gb = g * bands + band;
    __global const double *camera = fr->cameras + 16 * c, *joints = fr->joints;
    const int width = fr->shapes[3 * c], full_height = fr->shapes[3 * c + 1];
    const int band_lo = band * fr->band_rows;
    const int height = bands == 1 ? full_height : MIN(fr->band_rows, full_height - band_lo);
    const int stride = (width + 31) / 32;                               // words of a row
    const int pitch = (stride + PITCH_WORDS - 1) / PITCH_WORDS * PITCH_WORDS;  // words per row
    // padded layer: (height + 2 PAD) rows of pstride words
    const int pstride = (stride + COUNT_WORDS) / COUNT_WORDS * COUNT_WORDS;
    const int layer_words = pstride * (height + 2 * PAD);
    __global const uint *f = fr->fg + fr->shapes[3 * c + 2] + band_lo * pitch;
    __global uint *masks_out = fr->masks_out + g * fr->mask_words;
    __local uint *words = (__local uint *)mask;

    // the model points (none unless asked: K = 0), from the transforms at hand, by the
    // view's first band
    if (band_lo == 0)
        project_points(camera, T0, fr->K, fr->point_joint, fr->point_rest, lid,
                       fr->pixels + 2 * fr->K * g);
    if (height <= 0) {  // a band below a smaller camera's last row: nothing to count
        if (lid == 0) fr->counts[2 * gb] = fr->counts[2 * gb + 1] = 0;
        return;
    }

    // setup
    int side_of[MAX_LAYERS], layers;  // the distinct patch sides, one per layer
    const int layered = setup_view(camera, T0, joints, J, max_layers, width, height, pitch,
                                   layer_words, lid, mask, totals, side_of, &layers);
    barrier(CLK_LOCAL_MEM_FENCE);

    // the layered scatter or the direct stamp, joint by joint and block by block; a lane of
    // the layered path without a centre sets a bit of a sink word of its own
    const intV sink = 32 * max_layers * layer_words + 32 * LANE_INDEX;
    volatile intV pending = sink;
    Reach reach;
    reach.lo = height + 2 * PAD; reach.hi = -1;
    // the lanes' rows and columns: those of reach.lo and the totals less lane_pad (the
    // layered path's image ones)
    const int lane_pad = layered ? PAD : 0;
    reach.loV = (intV)(height + 2 * PAD - lane_pad); reach.hiV = (intV)(-1 - lane_pad);
    reach.leftV = (intV)(width + 2 * PAD - lane_pad); reach.rightV = (intV)(-1 - lane_pad);
    for (int j = 0; j < J; ++j) {
        __local const double *T = T0 + 12 * j;
        const int s = patch_side(camera, T, joints + 4 * j);
        if (s == 0) continue;
        float a[12], b[3];
        joint_coefficients(camera, T, a, b);
#if STOPS_AFTER(PART_SETUP)  // no vertex: the coefficients kept alive
        reach.lo = MIN(reach.lo, as_int(a[0]) ^ as_int(b[0]));
        continue;
#endif
        int l = 0;
        while (layered && side_of[l] != s) ++l;
        for (int blk = fr->joint_start[j] / BLOCK + lid; blk < fr->joint_start[j + 1] / BLOCK;
             blk += LOCAL_SIZE) {
            int all_facing;
            if (!block_may_face(fr->cones + 10 * blk, b, &all_facing)) continue;
            if (bands > 1
                && !block_meets_rows(fr->cones + 10 * blk, a, s, band_lo, band_lo + height - 1))
                continue;
            if (layered)
                scatter_centres(fr->vertices, blk, all_facing, a, b, width, height, pstride,
                                32 * l * layer_words + PAD * (32 * pstride + 1), sink, words,
                                &pending, &reach);
            else
                stamp_patches(fr->vertices, blk, all_facing, a, b, width, height, pitch, s,
                              band_lo, words, &reach);
        }
    }
#if KEPT(PART_ORS)
    if (layered) set_bits(words, &pending);
#endif
    MIN_INT(&totals->row_lo, MIN(reach.lo, min_lane(reach.loV) + lane_pad));
    MAX_INT(&totals->row_hi, MAX(reach.hi, max_lane(reach.hiV) + lane_pad));
    MIN_INT(&totals->col_lo, min_lane(reach.leftV) + lane_pad);
    MAX_INT(&totals->col_hi, max_lane(reach.rightV) + lane_pad);
    barrier(CLK_LOCAL_MEM_FENCE);

    // dilate-and-count, or count the stamped mask
    int model, overlap;
#if !KEPT(PART_COUNT)  // nothing counted: the reach kept alive
    model = totals->row_lo + totals->row_hi + totals->col_lo + totals->col_hi;
    overlap = 0;
#else
    if (layered)
        dilate_and_count(words, side_of, layers, layer_words, pstride, stride, pitch, width,
                         height, totals, f, lid, fr->write_masks, masks_out, &model, &overlap);
    else
        count_stamped(mask, (__global const uint8 *)f, totals->row_lo, totals->row_hi, pitch,
                      lid, &model, &overlap);
#endif
    ADD_INT(&totals->model_px, model);
    ADD_INT(&totals->overlap_px, overlap);
    barrier(CLK_LOCAL_MEM_FENCE);
    if (fr->write_masks && !layered)
        for (int k = lid; k < pitch * height; k += LOCAL_SIZE)
            masks_out[band_lo * pitch + k] = words[k];
    if (lid == 0) {  // per band: the host adds a view's bands up
        fr->counts[2 * gb] = totals->model_px;
        fr->counts[2 * gb + 1] = totals->overlap_px;
    }
}

__kernel __attribute__((reqd_work_group_size(LOCAL_SIZE, 1, 1)))
void silhouette_counts(
    __global const float *vertices,    // (N4 / LANES, 7, LANES) rest x, y, z (mm),
                                       // normal x, y, z, n . v
    __global const int *joint_start,   // (J + 1,) first vertex of each joint (multiples of BLOCK)
    __global const double *cones,      // (N4 / BLOCK, 10) normal cone axis (3), cos, sin,
                                       // sphere centre (3, mm), radius (mm), 1 if no padding
    __global const double *poses,      // with_chain: (n, 3 + 6 J) KinematicChain.pose_rows;
                                       // else (n, J, 12) T = [R t] (3x4, row-major, mm) of
                                       // each candidate's joints, body.transforms
    __global const double *chain,      // (J, 16) KinematicChain.rows (with_chain only)
    const int with_chain,              // 1: poses are pose rows, 0: transforms
    __local double *transforms,        // (J, 12) the candidate's transforms
    __global const double *cameras,    // (C, 16) P = [K[0] E; K[1] E; E[2]] (3x4, row-major),
                                       // centre (3, mm), focal (px): silhouette.camera_rows
    __global const double *joints,     // (J, 4) rest position (3, mm), patch (mm)
    __global const int *shapes,        // (C, 3) width, height, first word of the mask in fg
    __global const uint *fg,           // foreground bit masks, bit x % 32 of word x / 32 of
                                       // its row (pitch words), each camera's followed by
                                       // zeros to mask_words
    const int C, const int J,          // cameras, joints
    const int views_per_group,         // cameras per work-group: 1 .. C
    __local uint8 *mask,               // the largest camera's mask (with bands > 1: a band
                                       // of band_rows rows) + 1 spare word, or max_layers
                                       // of its padded layers (see PAD)
    const int max_layers,              // 0 .. MAX_LAYERS
    __global int *out,                 // (n C, bands, 2) |M|, |M & F| of each band, then
                                       // (n C, K, 2) float32 u, v (px) of each model point,
                                       // NaN behind
    const int write_masks, const int mask_words, // mask_words: a multiple of 8
    __global uint *masks_out,          // (n C, mask_words) when write_masks != 0
    const int K,                       // model points whose pixels to write, 0: none
    __global const int *point_joint,   // (K,) the joint each point rides on
    __global const float *point_rest,  // (K, 3) its rest position (mm)
    const int bands,                   // work-groups per view: 1, or the bands (max_layers 0)
    const int band_rows)               // rows of each band (with bands > 1)
{
    __local ViewTotals totals;
    // work-group gb: band gb % bands of cameras first .. first + views_per_group - 1 (at
    // most C - 1) of a candidate, in the order (candidate, camera group, band)
    const int gb = get_group_id(0), lid = get_local_id(0);
    const int groups = (C + views_per_group - 1) / views_per_group;  // camera groups
    const int candidate = gb / bands / groups, first = gb / bands % groups * views_per_group;
    const int views = get_num_groups(0) / bands / groups * C;  // n C
    const Frame fr = {vertices, joint_start, cones, cameras, joints, shapes, fg, J, max_layers,
                      bands, band_rows, write_masks, mask_words, K, masks_out, point_joint,
                      point_rest, out, (__global float *)(out + 2 * bands * views)};
    candidate_transforms(poses + candidate * (with_chain ? 3 + 6 * J : 12 * J), chain,
                         with_chain, J, lid, transforms);
    barrier(CLK_LOCAL_MEM_FENCE);
#if STOPS_AFTER(PART_CALL)  // the transforms alone
    return;
#endif
    for (int c = first; c < MIN(first + views_per_group, C); ++c) {
        count_view(&fr, candidate * C + c, c, gb % bands, transforms, mask, &totals, lid);
        barrier(CLK_LOCAL_MEM_FENCE);  // before the next view clears the mask and totals
    }
}
