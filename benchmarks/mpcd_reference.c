/* A hand-written MPCD (SRD) step in C with OpenMP: the reference that tells how close
 * to its bound a compiled loop gets on this machine (benchmarks/mpcd_reference.py).
 *
 * The same work per step as the jaxdpd step it is timed against (unit masses, cubic
 * box of `edge` cells of side 1, float32): streaming r += h v with the wrap into
 * [0, L) and the image counters; a random grid shift in [0, 1)^3; cell ids; per-cell
 * mass and momentum; per-cell random rotation axes (the lowbias32 hash of
 * jaxdpd.engine.noise, cos(theta) and phi uniform); the Rodrigues rotation of the
 * velocities relative to their cell's mean; the kinetic tensor (6 sums) of the new
 * velocities.  Each thread scatters into a table of its own, summed per cell after.
 *
 * Written for the compiler to vectorise every loop but the scatter (checked with
 * gcc 12 -O3 -march=native -fno-trapping-math -fno-math-errno -fopt-info-vec): flat
 * loops, selects instead of branches, the axes computed components first before they
 * join the per-cell table, and no fmaxf (gcc 12 does not vectorise it).  The scratch
 * tables are allocated in every call, which counts their page faults against C.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

/* Seconds spent in each of the step's seven loops, as seen by thread 0 (its share of
 * the loop and its wait at the loop's closing barrier), summed over calls: wrap,
 * cell ids, scatter, table sum, axes, per-cell table, rotation.  The zeroing of the
 * tables and the start of the parallel region are in none of them. */
double mpcd_loop_seconds[7];

static inline uint32_t mix32(uint32_t h) {
    h ^= h >> 16;
    h *= 0x21F0AAADu;
    h ^= h >> 15;
    h *= 0x735A2D97u;
    return h ^ (h >> 15);
}

static inline uint32_t site_bits(uint32_t key, uint32_t site, uint32_t stream) {
    return mix32(mix32(key ^ (site * 0x9E3779B9u + stream)) + site);
}

static inline float unit_interval(uint32_t bits) {
    return ((float)(bits >> 8) + 0.5f) * (1.0f / 16777216.0f);
}

/* sin(2 pi t) and cos(2 pi t) for t in [0, 1): quadrant reduction and Taylor series
 * to phi^9 and phi^8 on |phi| <= pi/4 (truncation below 3e-8), which vectorises. */
static inline void sincos_turns(float t, float *sine, float *cosine) {
    float quarter = 4 * t, quadrant = rintf(quarter);
    float phi = (quarter - quadrant) * 1.57079632679489662f, p2 = phi * phi;
    float s = phi * (1 + p2 * (-1.f / 6 + p2 * (1.f / 120 + p2 * (-1.f / 5040 + p2 * (1.f / 362880)))));
    float c = 1 + p2 * (-0.5f + p2 * (1.f / 24 + p2 * (-1.f / 720 + p2 * (1.f / 40320))));
    int q = (int)quadrant & 3;
    *sine = q == 0 ? s : q == 1 ? c : q == 2 ? -s : -c;
    *cosine = q == 0 ? c : q == 1 ? -s : q == 2 ? -c : s;
}

/* 64-byte aligned storage for `count` values of `size` bytes (NULL if none left). */
static void *allocate(size_t count, size_t size) {
    return aligned_alloc(64, (count * size + 63) / 64 * 64);
}

/* One step per iteration; kinetic receives 6 sums per step (xx yy zz xy xz yz).
 * Returns 0, or -1 when the scratch tables cannot be allocated. */
int mpcd_steps(int n, int edge, float *positions, float *velocities, int32_t *image,
               float h, float cos_angle, float sin_angle, uint32_t seed, int first_step,
               int steps, double *kinetic) {
    const int n_cells = edge * edge * edge;
    const float length = (float)edge;
    const float inverse_length = 1.0f / length;
    /* One scatter table per thread: as many as a parallel region may start. */
    float *tables = allocate((size_t)4 * n_cells * omp_get_max_threads(), sizeof(float));
    float *per_cell = allocate((size_t)8 * n_cells, sizeof(float));
    float *axes = allocate((size_t)3 * n_cells, sizeof(float));
    int32_t *cell = allocate((size_t)n, sizeof(int32_t));
    if (!tables || !per_cell || !axes || !cell) {
        free(tables), free(per_cell), free(axes), free(cell);
        return -1;
    }
    for (int step = first_step; step < first_step + steps; ++step) {
        const uint32_t key =
            mix32(mix32(seed ^ 0x5BD1E995u) + (uint32_t)(step + 1) * 0x9E3779B9u);
        float shift[3];
        for (int k = 0; k < 3; ++k) shift[k] = unit_interval(site_bits(key, 0, 16 + k));
        float kxx = 0, kyy = 0, kzz = 0, kxy = 0, kxz = 0, kyz = 0;
#pragma omp parallel
        {
            double clock[8];
            const int team = omp_get_num_threads(); /* may be fewer than the tables */
            float *table = tables + (size_t)4 * n_cells * omp_get_thread_num();
            memset(table, 0, sizeof(float) * 4 * (size_t)n_cells);
            clock[0] = omp_get_wtime();
#pragma omp for schedule(static)
            for (int j = 0; j < 3 * n; ++j) {
                float x = positions[j] + h * velocities[j];
                float crossings = floorf(x * inverse_length);
                x -= crossings * length;
                crossings -= x < 0, x = x < 0 ? x + length : x;
                crossings += x >= length, x = x >= length ? x - length : x;
                positions[j] = x;
                image[j] += (int32_t)crossings;
            }
            clock[1] = omp_get_wtime();
#pragma omp for schedule(static)
            for (int i = 0; i < n; ++i) {
                float sx = positions[3 * i] - shift[0];
                float sy = positions[3 * i + 1] - shift[1];
                float sz = positions[3 * i + 2] - shift[2];
                sx = sx < 0 ? sx + length : sx;
                sy = sy < 0 ? sy + length : sy;
                sz = sz < 0 ? sz + length : sz;
                /* In [0, L] for finite input; anything else (a NaN) goes to cell 0. */
                sx = sx >= 0 && sx <= length ? sx : 0;
                sy = sy >= 0 && sy <= length ? sy : 0;
                sz = sz >= 0 && sz <= length ? sz : 0;
                int cx = (int)sx, cy = (int)sy, cz = (int)sz;
                cx = cx >= edge ? cx - edge : cx;
                cy = cy >= edge ? cy - edge : cy;
                cz = cz >= edge ? cz - edge : cz;
                cell[i] = cx + edge * (cy + edge * cz);
            }
            clock[2] = omp_get_wtime();
#pragma omp for schedule(static)
            for (int i = 0; i < n; ++i) {
                float *slot = table + 4 * cell[i];
                const float *v = velocities + 3 * i;
                slot[0] += 1.0f, slot[1] += v[0], slot[2] += v[1], slot[3] += v[2];
            }
            clock[3] = omp_get_wtime();
            for (int t = 1; t < team; ++t) {
#pragma omp for schedule(static)
                for (int j = 0; j < 4 * n_cells; ++j)
                    tables[j] += tables[(size_t)4 * n_cells * t + j];
            }
            clock[4] = omp_get_wtime();
#pragma omp for simd schedule(simd : static)
            for (int c = 0; c < n_cells; ++c) {
                float cos_theta = 2 * unit_interval(site_bits(key, c, 0)) - 1;
                float sin_squared = 1 - cos_theta * cos_theta; /* fmaxf would not vectorise */
                float sin_theta = sqrtf(sin_squared > 0 ? sin_squared : 0);
                float sin_phi, cos_phi;
                sincos_turns(unit_interval(site_bits(key, c, 1)), &sin_phi, &cos_phi);
                axes[c] = sin_theta * cos_phi;
                axes[n_cells + c] = sin_theta * sin_phi;
                axes[2 * n_cells + c] = cos_theta;
            }
            clock[5] = omp_get_wtime();
#pragma omp for schedule(static)
            for (int c = 0; c < n_cells; ++c) {
                float mass = tables[4 * c];
                float inverse_mass = mass > 0 ? 1.0f / mass : 0.0f;
                float *out = per_cell + 8 * c;
                out[0] = tables[4 * c + 1] * inverse_mass;
                out[1] = tables[4 * c + 2] * inverse_mass;
                out[2] = tables[4 * c + 3] * inverse_mass;
                out[3] = axes[c];
                out[4] = axes[n_cells + c];
                out[5] = axes[2 * n_cells + c];
            }
            clock[6] = omp_get_wtime();
#pragma omp for simd schedule(simd : static) reduction(+ : kxx, kyy, kzz, kxy, kxz, kyz)
            for (int i = 0; i < n; ++i) {
                const float *u = per_cell + 8 * cell[i];
                float *v = velocities + 3 * i;
                float wx = v[0] - u[0], wy = v[1] - u[1], wz = v[2] - u[2];
                float nx = u[3], ny = u[4], nz = u[5];
                float along = (nx * wx + ny * wy + nz * wz) * (1 - cos_angle);
                float x = u[0] + wx * cos_angle + (ny * wz - nz * wy) * sin_angle + nx * along;
                float y = u[1] + wy * cos_angle + (nz * wx - nx * wz) * sin_angle + ny * along;
                float z = u[2] + wz * cos_angle + (nx * wy - ny * wx) * sin_angle + nz * along;
                v[0] = x, v[1] = y, v[2] = z;
                kxx += x * x, kyy += y * y, kzz += z * z;
                kxy += x * y, kxz += x * z, kyz += y * z;
            }
            clock[7] = omp_get_wtime();
            if (omp_get_thread_num() == 0)
                for (int loop = 0; loop < 7; ++loop)
                    mpcd_loop_seconds[loop] += clock[loop + 1] - clock[loop];
        }
        double *out = kinetic + 6 * (size_t)(step - first_step);
        out[0] = kxx, out[1] = kyy, out[2] = kzz, out[3] = kxy, out[4] = kxz, out[5] = kyz;
    }
    free(tables), free(per_cell), free(axes), free(cell);
    return 0;
}
