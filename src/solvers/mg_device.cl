/* mg_device.cl — solver=mg's kernels on an OpenCL device: each of the
 * multigrid's operations (mg_ops.h) that mg_device.c launches, for the
 * cycle and the outer iteration of mg_cycle.c: the outer flexible CG's steps
 * in double on the network's stencil, the K-cycle's in single precision on
 * the hierarchy's, the same arithmetic as the host's (mg.c).
 * Built with -D WG=<work-group size>.  A reduction's kernel runs a fixed
 * number of work-groups over the vector (a grid-stride loop) and writes
 * one partial sum per group; the host adds them in order, so a solve gives
 * the same bits on a given device every time. */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable

/* ---- stencil rows: sum of the neighbours' links times x, and the diagonal ---- */

/* (A x)_v for the network's stencil (in double, from its single-precision
 * links), in flux form, as the host's net_apply (physics/stencil_rows.h):
 * sink_v x_v + sum_w g_vw (x_v - x_w), so that the rows' sum keeps the
 * power balance's digits.  off[v] = (-y, +y, -z, +z) offsets (0: none), g
 * three +x, +y, +z conductances per cell, sink the ground and boundary
 * (physics/stencil_form.h's ohm_stencil). */
inline double net_apply(__global const int4 *off, __global const float *g, __global const double *sink,
                        __global const double *x, long v, long n)
{
    int4 o = off[v];
    double xv = x[v];
    double s = sink[v] * xv + g[3 * v + 1] * (xv - x[v + o.y]) + g[3 * v + 2] * (xv - x[v + o.w]);
    if (v < n - 1) s += g[3 * v] * (xv - x[v + 1]);
    if (v > 0) s += g[3 * (v - 1)] * (xv - x[v - 1]);
    if (o.x) s += g[3 * (v + o.x) + 1] * (xv - x[v + o.x]);
    if (o.z) s += g[3 * (v + o.z) + 2] * (xv - x[v + o.z]);
    return s;
}

/* the cycle's (single): c[v] = (+x, +y, +z links, sink) */
inline float cyc_row(__global const int4 *off, __global const float4 *c, __global const float *x, long v, long n)
{
    int4 o = off[v];
    float4 cv = c[v];
    float s = cv.y * x[v + o.y] + cv.z * x[v + o.w];
    if (v < n - 1) s += cv.x * x[v + 1];
    if (v > 0) s += c[v - 1].x * x[v - 1];
    if (o.x) s += c[v + o.x].y * x[v + o.x];
    if (o.z) s += c[v + o.z].z * x[v + o.z];
    return s;
}

inline float cyc_diag(__global const int4 *off, __global const float4 *c, long v, long n)
{
    int4 o = off[v];
    float4 cv = c[v];
    float d = cv.y + cv.z + cv.w;
    if (v < n - 1) d += cv.x;
    if (v > 0) d += c[v - 1].x;
    if (o.x) d += c[v + o.x].y;
    if (o.z) d += c[v + o.z].z;
    return d;
}

/* Level 0's links beyond the grid (the clear regions' coupling:
 * physics/stencil_form.h), row v's entries xs[v] .. xs[v + 1] - 1 of xc
 * (the other unknown) and xg; has_x 0: none (the buffers unread).  The
 * flux form's terms in double, and in the cycle's single precision their
 * sum g x_w and their share of the diagonal. */
#define EXTRA_ARGS __global const long *xs, __global const int *xc, __global const float *xg, int has_x
inline double net_extra(EXTRA_ARGS, __global const double *x, long v)
{
    double s = 0;
    if (has_x)
        for (long k = xs[v]; k < xs[v + 1]; ++k) s += xg[k] * (x[v] - x[xc[k]]);
    return s;
}

inline float cyc_extra(EXTRA_ARGS, __global const float *x, long v, float *diag)
{
    float s = 0, d = 0;
    if (has_x)
        for (long k = xs[v]; k < xs[v + 1]; ++k) {
            s += xg[k] * x[xc[k]];
            d += xg[k];
        }
    *diag = d;
    return s;
}

/* a coarse level's row (sparse: solvers/mg_coarsen.h): entries rp[v] ..
 * rp[v + 1] - 1 of cv, (column, g) pairs with the column's bits in a
 * float's, the first the row's sink (column -1).  Its links' sum g x_w,
 * its diagonal into *diag, summed in the host's order (solvers/mg.c's
 * LEVEL_ROWS). */
inline float sp_row(__global const long *rp, __global const float2 *cv, __global const float *x, long v, float *diag)
{
    float s = 0, d = 0;
    for (long k = rp[v]; k < rp[v + 1]; ++k) {
        float2 e = cv[k];
        int c = as_int(e.x);
        d += e.y;
        if (c >= 0) s += e.y * x[c];
    }
    *diag = d;
    return s;
}

/* ---- reductions: one or two sums per work-group ---- */

inline void group_sum2(double a, double b, __local double *sa, __local double *sb, __global double *partial)
{
    int l = get_local_id(0);
    sa[l] = a;
    sb[l] = b;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int h = WG / 2; h > 0; h >>= 1) {
        if (l < h) {
            sa[l] += sa[l + h];
            sb[l] += sb[l + h];
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0) {
        partial[2 * get_group_id(0)] = sa[0];
        partial[2 * get_group_id(0) + 1] = sb[0];
    }
}

#define GRID_LOOP(v, n) for (long v = get_global_id(0); v < (n); v += get_global_size(0))

/* ---- the outer iteration (double) ---- */

/* r = b - A x; partials ||r||^2 and sum r */
__kernel void net_residual(__global const int4 *off, __global const float *g, __global const double *sink,
                           __global const double *x, __global const double *b, __global double *r, long n,
                           __global double *partial, EXTRA_ARGS)
{
    __local double sa[WG], sb[WG];
    double s2 = 0, s1 = 0;
    GRID_LOOP(v, n)
    {
        double rv = b[v] - net_apply(off, g, sink, x, v, n) - net_extra(xs, xc, xg, has_x, x, v);
        r[v] = rv;
        s2 += rv * rv;
        s1 += rv;
    }
    group_sum2(s2, s1, sa, sb, partial);
}

/* q = A p; partials p.q and p.r */
__kernel void net_apply_dots(__global const int4 *off, __global const float *g, __global const double *sink,
                             __global const double *p, __global const double *r, __global double *q, long n,
                             __global double *partial, EXTRA_ARGS)
{
    __local double sa[WG], sb[WG];
    double pq = 0, pr = 0;
    GRID_LOOP(v, n)
    {
        double qv = net_apply(off, g, sink, p, v, n) + net_extra(xs, xc, xg, has_x, p, v);
        q[v] = qv;
        pq += p[v] * qv;
        pr += p[v] * r[v];
    }
    group_sum2(pq, pr, sa, sb, partial);
}

/* x += alpha p, r -= alpha q; partials ||r||^2 and sum r */
__kernel void outer_step(__global double *x, __global double *r, __global const double *p, __global const double *q,
                   double alpha, long n, __global double *partial)
{
    __local double sa[WG], sb[WG];
    double s2 = 0, s1 = 0;
    GRID_LOOP(i, n)
    {
        x[i] += alpha * p[i];
        double ri = r[i] - alpha * q[i];
        r[i] = ri;
        s2 += ri * ri;
        s1 += ri;
    }
    group_sum2(s2, s1, sa, sb, partial);
}

/* bf = s r, in single precision */
__kernel void to_single(__global const double *r, __global float *bf, double s, long n)
{
    GRID_LOOP(i, n) bf[i] = (float)(s * r[i]);
}

/* partial z.q */
__kernel void mixed_dot(__global const float *z, __global const double *q, long n, __global double *partial)
{
    __local double sa[WG], sb[WG];
    double s = 0;
    GRID_LOOP(i, n) s += (double)z[i] * q[i];
    group_sum2(s, 0, sa, sb, partial);
}

/* p = a z - beta p */
__kernel void direction(__global const float *z, __global double *p, double a, double beta, long n)
{
    if (beta == 0) {
        GRID_LOOP(i, n) p[i] = a * z[i];
    } else {
        GRID_LOOP(i, n) p[i] = a * z[i] - beta * p[i];
    }
}

/* x = 0 where x < 0 (a nonnegative source has a nonnegative solution: mg_cycle.c) */
__kernel void clamp_negative(__global double *x, long n)
{
    GRID_LOOP(i, n) if (x[i] < 0) x[i] = 0;
}

/* ---- the cycle (single) ---- */

/* out = w D^-1 b: the first Chebyshev step from zero */
__kernel void jacobi0(__global const float *b, __global const float *invd, __global float *out, float w, long n)
{
    GRID_LOOP(v, n) out[v] = w * b[v] * invd[v];
}

/* out = x + w D^-1 (b - A x): the first Chebyshev step from x */
__kernel void jacobi(__global const int4 *off, __global const float4 *c, __global const float *invd,
                     __global const float *x, __global const float *b, __global float *out, float w, long n,
                     EXTRA_ARGS)
{
    GRID_LOOP(v, n)
    {
        float dx, row = cyc_row(off, c, x, v, n) + cyc_extra(xs, xc, xg, has_x, x, v, &dx);
        out[v] = x[v] + w * ((b[v] + row) * invd[v] - x[v]);
    }
}

/* out = x + a (x - y) + a2 D^-1 (b - A x); y absent: 0 (has_y 0) */
__kernel void cheb(__global const int4 *off, __global const float4 *c, __global const float *invd,
                   __global const float *x, __global const float *y, int has_y, __global const float *b,
                   __global float *out, float a, float a2, long n, EXTRA_ARGS)
{
    GRID_LOOP(v, n)
    {
        float dx, xv = x[v], yv = has_y ? y[v] : 0.0f;
        float row = cyc_row(off, c, x, v, n) + cyc_extra(xs, xc, xg, has_x, x, v, &dx);
        float jac = (b[v] + row) * invd[v] - xv;
        out[v] = xv + a * (xv - yv) + a2 * jac;
    }
}

/* t = b - A x */
__kernel void cyc_residual(__global const int4 *off, __global const float4 *c, __global const float *x,
                           __global const float *b, __global float *t, long n, EXTRA_ARGS)
{
    GRID_LOOP(v, n)
    {
        float dx, row = cyc_row(off, c, x, v, n) + cyc_extra(xs, xc, xg, has_x, x, v, &dx);
        t[v] = b[v] - ((cyc_diag(off, c, v, n) + dx) * x[v] - row);
    }
}

/* rc[I] = sum of t over coarse cell I's fine cells (children[start[I] ..
 * start[I + 1]]) */
__kernel void gather(__global const float *t, __global const long *start, __global const int *children,
                     __global float *rc, long nc)
{
    GRID_LOOP(I, nc)
    {
        float s = 0;
        for (long k = start[I]; k < start[I + 1]; ++k) s += t[children[k]];
        rc[I] = s;
    }
}

/* out = x + e[agg] */
__kernel void prolong(__global const float *x, __global const float *e, __global const int *agg,
                      __global float *out, long n)
{
    GRID_LOOP(v, n) out[v] = x[v] + e[agg[v]];
}

/* y = A x; partial x.q (has_q) or x.y */
__kernel void cyc_apply_dot(__global const int4 *off, __global const float4 *c, __global const float *x,
                            __global float *y, __global const float *q, int has_q, long n, __global double *partial,
                            EXTRA_ARGS)
{
    __local double sa[WG], sb[WG];
    double s = 0;
    GRID_LOOP(v, n)
    {
        float dx, row = cyc_row(off, c, x, v, n) + cyc_extra(xs, xc, xg, has_x, x, v, &dx);
        float yv = (cyc_diag(off, c, v, n) + dx) * x[v] - row;
        y[v] = yv;
        s += (double)x[v] * (has_q ? (double)q[v] : (double)yv);
    }
    group_sum2(s, 0, sa, sb, partial);
}

/* The same four on a coarse level's sparse rows (rp, cv: sp_row) */
__kernel void jacobi_sp(__global const long *rp, __global const float2 *cv, __global const float *invd,
                        __global const float *x, __global const float *b, __global float *out, float w, long n)
{
    GRID_LOOP(v, n)
    {
        float d;
        out[v] = x[v] + w * ((b[v] + sp_row(rp, cv, x, v, &d)) * invd[v] - x[v]);
    }
}

__kernel void cheb_sp(__global const long *rp, __global const float2 *cv, __global const float *invd,
                      __global const float *x, __global const float *y, int has_y, __global const float *b,
                      __global float *out, float a, float a2, long n)
{
    GRID_LOOP(v, n)
    {
        float d, xv = x[v], yv = has_y ? y[v] : 0.0f;
        float jac = (b[v] + sp_row(rp, cv, x, v, &d)) * invd[v] - xv;
        out[v] = xv + a * (xv - yv) + a2 * jac;
    }
}

__kernel void cyc_residual_sp(__global const long *rp, __global const float2 *cv, __global const float *x,
                              __global const float *b, __global float *t, long n)
{
    GRID_LOOP(v, n)
    {
        float d, s = sp_row(rp, cv, x, v, &d);
        t[v] = b[v] - (d * x[v] - s);
    }
}

__kernel void cyc_apply_dot_sp(__global const long *rp, __global const float2 *cv, __global const float *x,
                               __global float *y, __global const float *q, int has_q, long n,
                               __global double *partial)
{
    __local double sa[WG], sb[WG];
    double s = 0;
    GRID_LOOP(v, n)
    {
        float d, row = sp_row(rp, cv, x, v, &d);
        float yv = d * x[v] - row;
        y[v] = yv;
        s += (double)x[v] * (has_q ? (double)q[v] : (double)yv);
    }
    group_sum2(s, 0, sa, sb, partial);
}

__kernel void cycle_dot(__global const float *x, __global const float *y, long n, __global double *partial)
{
    __local double sa[WG], sb[WG];
    double s = 0;
    GRID_LOOP(i, n) s += (double)x[i] * y[i];
    group_sum2(s, 0, sa, sb, partial);
}

__kernel void fill_zero(__global float *x, long n)
{
    GRID_LOOP(i, n) x[i] = 0.0f;
}

/* out = a x + a2 y (has_y 0: a x) */
__kernel void combine(__global const float *x, __global const float *y, int has_y, __global float *out, double a,
                      double a2, long n)
{
    GRID_LOOP(i, n) out[i] = (float)(a * x[i] + (has_y ? a2 * y[i] : 0.0));
}

/* The coarsest level: x = (L L^T)^-1 b by the dense factor (row-major,
 * lower), in double, by one work-group: each row's sum over the group. */
__kernel void dense_solve(__global const double *Lf, __global const float *b, __global double *y,
                          __global float *x, long n)
{
    __local double part[WG];
    int l = get_local_id(0);
    for (long i = 0; i < n; ++i) { /* L y = b */
        double s = 0;
        for (long j = l; j < i; j += WG) s += Lf[i * n + j] * y[j];
        part[l] = s;
        barrier(CLK_LOCAL_MEM_FENCE);
        for (int h = WG / 2; h > 0; h >>= 1) {
            if (l < h) part[l] += part[l + h];
            barrier(CLK_LOCAL_MEM_FENCE);
        }
        if (l == 0) y[i] = (b[i] - part[0]) / Lf[i * n + i];
        barrier(CLK_GLOBAL_MEM_FENCE | CLK_LOCAL_MEM_FENCE);
    }
    for (long i = n - 1; i >= 0; --i) { /* L^T x = y */
        double s = 0;
        for (long j = i + 1 + l; j < n; j += WG) s += Lf[j * n + i] * y[j];
        part[l] = s;
        barrier(CLK_LOCAL_MEM_FENCE);
        for (int h = WG / 2; h > 0; h >>= 1) {
            if (l < h) part[l] += part[l + h];
            barrier(CLK_LOCAL_MEM_FENCE);
        }
        if (l == 0) y[i] = (y[i] - part[0]) / Lf[i * n + i];
        barrier(CLK_GLOBAL_MEM_FENCE | CLK_LOCAL_MEM_FENCE);
    }
    for (long i = l; i < n; i += WG) x[i] = (float)y[i];
}
