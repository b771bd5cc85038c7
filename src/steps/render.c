/* render.c — `-render`: preview images of the solution (see render.h). */
#include "steps/render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <embree3/rtcore.h>

#include "base/vec3.h"
#include "physics/light_kind.h"
#include "ohm_oiio.h"

const ohm_opt_spec ohm_render_opts[] = {
    {"file", OHM_OPT_STRING, NULL, "output image: .png (8-bit sRGB) or .exr (half float, linear)", NULL, 0, 0, 1},
    {"size", OHM_OPT_STRING, "640,480", "W,H in pixels: the whole image (with compare=1, two W/2 x H panels)", NULL,
     0, 0, 0},
    {"compare", OHM_OPT_INT, "0", "1: put the same view without scattering (Lambert, shadow rays) on the right",
     NULL, 0, 1, 0},
    {"view", OHM_OPT_VEC3, NULL,
     "direction the camera looks (default: the way the frame's first light travels, else 0,0,-1)", NULL, 0, 0, 0},
    {"exposure", OHM_OPT_REAL, NULL, "multiplier on exitance (mm^2/W); default: the 99th percentile of what is seen "
     "maps to 1", NULL, 1e-300, 1e300, 0},
    {"frame", OHM_OPT_INT, "1", "which frame of an orbit to show", NULL, 1, 1000000, 0},
    {0}};

enum { SUPERSAMPLE = 2 };        /* SUPERSAMPLE^2 rays per pixel */
static const float BACKGROUND = 0.03f; /* linear grey: sRGB ~ 48/255 */

typedef struct render_ctx {
    const ohm_state *s;
    const ohm_network *net;
    int frame;                 /* 0-based */
    int channels;
    RTCDevice device;
    RTCScene scene;
    double eps;                /* offset for shadow rays (mm) */
    double *vnormal;           /* 3 per vertex: area-weighted, for smooth shading */
    double *exitance[3];       /* per unknown, this frame, per channel (solve.h) */
    ohm_light_setup *setups;   /* one per light (compare=1) */
} render_ctx;

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static int parse_size(const char *text, int *w, int *h)
{
    char *end;
    long a = strtol(text, &end, 10);
    if (end == text || *end != ',') return 0;
    const char *q = end + 1;
    long b = strtol(q, &end, 10);
    if (end == q || *end != '\0') return 0;
    if (a < 1 || b < 1 || a > 16384 || b > 16384) return 0;
    *w = (int)a;
    *h = (int)b;
    return 1;
}

/* ---- the scene ---------------------------------------------------------------- */

static void scene_free(render_ctx *r)
{
    if (r->scene) rtcReleaseScene(r->scene);
    if (r->device) rtcReleaseDevice(r->device);
    r->scene = NULL;
    r->device = NULL;
}

static int scene_build(render_ctx *r, const ohm_mesh *mesh, ohm_error *err)
{
    return ohm_embree_mesh_scene(&r->device, &r->scene, mesh, NULL, NULL, "-render", err);
}

static int occluded(const render_ctx *r, const double p[3], const double l[3], double tmax)
{
    return ohm_embree_occluded(r->scene, p, l, tmax);
}

/* ---- shading ------------------------------------------------------------------- */

/* Does interior cell (i,j,k) have a boundary face (an outside neighbour)? */
static int boundary_cell(const ohm_voxel_grid *g, const ohm_network *net, int32_t i, int32_t j, int32_t k)
{
    if (i < 0 || j < 0 || k < 0 || i >= g->dims[0] || j >= g->dims[1] || k >= g->dims[2]) return 0;
    if (ohm_network_unknown(net, ohm_voxel_index(g, i, j, k)) < 0) return 0;
    for (int d = 0; d < 6; ++d) {
        int32_t a = i + ohm_face_offset[d][0], b = j + ohm_face_offset[d][1], c = k + ohm_face_offset[d][2];
        if (a < 0 || b < 0 || c < 0 || a >= g->dims[0] || b >= g->dims[1] || c >= g->dims[2]) return 1;
        if (!g->inside[ohm_voxel_index(g, a, b, c)]) return 1; /* not: below a depth band */
    }
    return 0;
}

static void cell_exitance(const render_ctx *r, int32_t i, int32_t j, int32_t k, double w, double out[3])
{
    int64_t v = ohm_network_unknown(r->net, ohm_voxel_index(&r->s->grid, i, j, k));
    for (int c = 0; c < 3; ++c) {
        int cc = r->channels == 1 ? 0 : c;
        out[c] += w * r->exitance[cc][v];
    }
}

/* Exitance (W/mm^2) at a surface point: a tent filter two cells wide over the
 * boundary cells among the 4 x 4 x 4 around it (the solution is per cell, and
 * its light enters through axis-aligned faces: a narrower filter shows the
 * voxel steps), else the nearest boundary cell within two. */
static void exitance_at(const render_ctx *r, const double p[3], double out[3])
{
    const ohm_voxel_grid *g = &r->s->grid;
    double u[3];
    int32_t i0[3];
    for (int a = 0; a < 3; ++a) {
        u[a] = (p[a] - g->origin[a]) / g->h;
        i0[a] = (int32_t)floor(u[a]);
    }
    out[0] = out[1] = out[2] = 0;
    double wsum = 0;
    for (int32_t dk = -1; dk <= 2; ++dk)
        for (int32_t dj = -1; dj <= 2; ++dj)
            for (int32_t di = -1; di <= 2; ++di) {
                int32_t c[3] = {i0[0] + di, i0[1] + dj, i0[2] + dk};
                double w = 1;
                for (int a = 0; a < 3; ++a) w *= fmax(0.0, 1.0 - 0.5 * fabs(c[a] - u[a]));
                if (w <= 0 || !boundary_cell(g, r->net, c[0], c[1], c[2])) continue;
                cell_exitance(r, c[0], c[1], c[2], w, out);
                wsum += w;
            }
    if (wsum > 0) {
        for (int a = 0; a < 3; ++a) out[a] /= wsum;
        return;
    }
    double best = INFINITY;
    int32_t bc[3] = {0, 0, 0};
    int32_t n0[3];
    for (int a = 0; a < 3; ++a) n0[a] = (int32_t)lround(u[a]);
    for (int32_t dk = -2; dk <= 2; ++dk)
        for (int32_t dj = -2; dj <= 2; ++dj)
            for (int32_t di = -2; di <= 2; ++di) {
                int32_t c[3] = {n0[0] + di, n0[1] + dj, n0[2] + dk};
                if (!boundary_cell(g, r->net, c[0], c[1], c[2])) continue;
                double d2 = 0;
                for (int a = 0; a < 3; ++a) d2 += (c[a] - u[a]) * (c[a] - u[a]);
                if (d2 < best) best = d2, bc[0] = c[0], bc[1] = c[1], bc[2] = c[2];
            }
    if (isfinite(best)) cell_exitance(r, bc[0], bc[1], bc[2], 1.0, out);
}

/* ohm_light_visibility for a surface point of the preview: its origin
 * (lifted off the surface by eps) sees the light unless the mesh is in the way. */
typedef struct point_view {
    const render_ctx *r;
    double org[3];
} point_view;

static double point_visibility(const void *ctx, const double l[3], double dist)
{
    const point_view *pv = ctx;
    return occluded(pv->r, pv->org, l, isfinite(dist) ? dist - pv->r->eps : dist) ? 0.0 : 1.0;
}

/* Irradiance (W/mm^2 per channel) at surface point p with unit normal n, from
 * every light of the frame, with shadow rays: the table of light kinds'
 * (physics/light_kind.h), as the solver's faces get it.  A pencil beam
 * enters at one point and brings none. */
static void irradiance_at(const render_ctx *r, const double p[3], const double n[3], double out[3])
{
    out[0] = out[1] = out[2] = 0;
    point_view pv = {r, {0, 0, 0}};
    for (int a = 0; a < 3; ++a) pv.org[a] = p[a] + r->eps * n[a];
    for (size_t i = 0; i < r->s->nlights; ++i) {
        if (!ohm_light_in_frame(&r->s->lights[i], r->frame)) continue;
        double E[3], l_mean[3];
        ohm_light_irradiance(&r->setups[i], p, n, point_visibility, &pv, E, l_mean);
        for (int c = 0; c < 3; ++c) out[c] += E[c];
    }
}

/* The lights' setups (area samples, sky directions), PREVIEW_RAYS at most
 * per point: every pixel of the no-scattering panel asks each light. */
enum { PREVIEW_RAYS = 32 };

static int setups_init(render_ctx *r, ohm_error *err)
{
    size_t n = r->s->nlights;
    r->setups = calloc(n ? n : 1, sizeof *r->setups);
    if (!r->setups) return ohm_fail(err, OHM_ERR_NOMEM, "-render: out of memory");
    for (size_t i = 0; i < n; ++i) {
        int rc = ohm_light_setup_init(&r->setups[i], &r->s->lights[i], PREVIEW_RAYS, err);
        if (rc) return rc;
    }
    return OHM_OK;
}

static void setups_free(render_ctx *r)
{
    for (size_t i = 0; r->setups && i < r->s->nlights; ++i) ohm_light_setup_free(&r->setups[i]);
    free(r->setups);
    r->setups = NULL;
}

/* Per-channel reflectance for the no-scattering image: the power the solution
 * lets out in this frame over the power the lights put on the mesh, so both
 * images carry the same total power out. */
static void lambert_albedo(const render_ctx *r, double albedo[3])
{
    const ohm_state *s = r->s;
    const ohm_solution *sol = ohm_state_solution(s);
    const ohm_mesh *m = &s->mesh;
    double out_power[3] = {0, 0, 0}, in_power[3] = {0, 0, 0};
    int64_t nf = sol->net.nfaces;
    for (int c = 0; c < 3; ++c) {
        int cc = r->channels == 1 ? 0 : c;
        if (sol->face_exitance[cc])
            for (int64_t f = 0; f < nf; ++f) out_power[c] += ohm_solution_face_power(sol, cc, r->frame, f);
        else out_power[c] = sol->power_out_channel[cc] / sol->frames;
    }
    double orient = s->mesh_flipped ? -1.0 : 1.0;
    for (size_t t = 0; t < m->ntris; ++t) {
        const double *a = m->verts + 3 * m->tris[3 * t], *b = m->verts + 3 * m->tris[3 * t + 1],
                     *c = m->verts + 3 * m->tris[3 * t + 2];
        double e1[3], e2[3], nn[3], p[3];
        for (int k = 0; k < 3; ++k) {
            e1[k] = b[k] - a[k];
            e2[k] = c[k] - a[k];
            p[k] = (a[k] + b[k] + c[k]) / 3.0;
        }
        cross3(e1, e2, nn);
        double area = 0.5 * sqrt(dot3(nn, nn));
        if (!ohm_vec3_normalize(nn)) continue;
        for (int k = 0; k < 3; ++k) nn[k] *= orient;
        double E[3];
        irradiance_at(r, p, nn, E);
        for (int k = 0; k < 3; ++k) in_power[k] += area * E[k];
    }
    for (int c = 0; c < 3; ++c) albedo[c] = in_power[c] > 0 ? out_power[c] / in_power[c] : 0.0;
}

/* Area-weighted vertex normals (orientation as wound), for smooth Lambert shading. */
static double *vertex_normals(const ohm_mesh *m)
{
    double *vn = calloc(3 * (m->nverts ? m->nverts : 1), sizeof *vn);
    if (!vn) return NULL;
    for (size_t t = 0; t < m->ntris; ++t) {
        const int64_t *ti = m->tris + 3 * t;
        const double *a = m->verts + 3 * ti[0], *b = m->verts + 3 * ti[1], *c = m->verts + 3 * ti[2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]}, nn[3];
        cross3(e1, e2, nn);
        for (int k = 0; k < 3; ++k)
            for (int q = 0; q < 3; ++q) vn[3 * ti[k] + q] += nn[q];
    }
    for (size_t v = 0; v < m->nverts; ++v) ohm_vec3_normalize(vn + 3 * v);
    return vn;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ---- the request -------------------------------------------------------------- */

/* What one -render asked for, checked against the state it runs on. */
typedef struct render_request {
    const char *path;
    int W, H;    /* the whole image */
    int pw, ph;  /* one panel: the whole image, or its left half with compare=1 */
    int compare;
    int frame;   /* 1-based, as given */
} render_request;

static int read_request(render_request *q, const ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    q->path = ohm_opt_str(inv, "file");
    if (!ohm_image_format_supported(q->path))
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -render file=%s: unsupported image format: use .png or .exr",
                        inv->where, q->path);
    if (!parse_size(ohm_opt_str(inv, "size"), &q->W, &q->H))
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -render size=%s: expected W,H (integers 1..16384)", inv->where,
                        ohm_opt_str(inv, "size"));
    q->compare = (int)ohm_opt_int(inv, "compare");
    if (q->compare && q->W < 2)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -render compare=1 needs a width of at least 2", inv->where);
    if (!s->have_solution)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -render: no solution yet: put -solve before it", inv->where);
    if (!s->have_mesh || s->mesh.ntris == 0)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -render: needs the mesh the solution was computed on", inv->where);
    const ohm_solution *sol = ohm_state_solution(s);
    q->frame = (int)ohm_opt_int(inv, "frame");
    if (q->frame > sol->frames)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -render frame=%d: the solution has %d frame(s)", inv->where, q->frame,
                        sol->frames);
    q->pw = q->compare ? q->W / 2 : q->W;
    q->ph = q->H;
    return OHM_OK;
}

/* ---- the camera ----------------------------------------------------------------- */

/* Orthographic, looking along f at the centre of the mesh's box, framing the box
 * with 5% to spare; rays start 2 radii + 1 mm before the centre. */
typedef struct camera {
    double centre[3], radius; /* the mesh's bounding box: centre, half diagonal (mm) */
    double f[3], right[3], up[3];
    double hw, hh;            /* half width and height of the view (mm) */
} camera;

/* view=, else the way the frame's first light travels (towards the centre for
 * a light with a position), else down -z. */
static int view_direction(double f[3], const render_ctx *r, const double centre[3], const ohm_invocation *inv,
                          ohm_error *err)
{
    const ohm_state *s = r->s;
    f[0] = 0, f[1] = 0, f[2] = -1;
    if (ohm_opt_given(inv, "view")) {
        ohm_opt_vec3(inv, "view", f);
        if (!ohm_vec3_normalize(f))
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -render view=0,0,0 has no direction", inv->where);
        return OHM_OK;
    }
    for (size_t i = 0; i < s->nlights; ++i) {
        const ohm_light *L = &s->lights[i];
        double d[3];
        if (!ohm_light_in_frame(L, r->frame) || !ohm_light_toward(L, centre, d)) continue;
        for (int a = 0; a < 3; ++a) f[a] = -d[a]; /* the way its light travels */
        break;
    }
    return OHM_OK;
}

static int camera_setup(camera *cam, const render_ctx *r, const render_request *q, const ohm_invocation *inv,
                        ohm_error *err)
{
    double lo[3], hi[3];
    ohm_mesh_bounds(&r->s->mesh, lo, hi);
    cam->radius = 0;
    for (int a = 0; a < 3; ++a) {
        cam->centre[a] = 0.5 * (lo[a] + hi[a]);
        cam->radius += 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
    }
    cam->radius = sqrt(cam->radius);
    int rc = view_direction(cam->f, r, cam->centre, inv, err);
    if (rc) return rc;
    const double *f = cam->f;
    double uphint[3] = {0, 1, 0};
    if (fabs(f[1]) > 0.99) uphint[1] = 0, uphint[2] = f[1] > 0 ? 1 : -1;
    cross3(f, uphint, cam->right);
    ohm_vec3_normalize(cam->right);
    cross3(cam->right, f, cam->up);
    double xr = 0, yr = 0;
    for (int k = 0; k < 8; ++k) {
        double c[3] = {(k & 1) ? hi[0] : lo[0], (k & 2) ? hi[1] : lo[1], (k & 4) ? hi[2] : lo[2]};
        for (int a = 0; a < 3; ++a) c[a] -= cam->centre[a];
        xr = fmax(xr, fabs(dot3(c, cam->right)));
        yr = fmax(yr, fabs(dot3(c, cam->up)));
    }
    double aspect = (double)q->pw / q->ph;
    cam->hw = 1.05 * fmax(fmax(xr, yr * aspect), 1e-9);
    cam->hh = cam->hw / aspect;
    return OHM_OK;
}

/* ---- tracing -------------------------------------------------------------------- */

/* Per pixel of a panel, sums over its SUPERSAMPLE^2 rays: what the scattering
 * panel sees and, with compare=1, what the no-scattering one does. */
typedef struct samples {
    size_t npx;
    double *scat;        /* 3 per pixel: the exitance seen */
    double *lamb;        /* 3 per pixel: the no-scattering radiance (compare=1) */
    unsigned char *hits; /* rays that met the mesh */
} samples;

static int samples_alloc(samples *sm, int pw, int ph)
{
    sm->npx = (size_t)pw * (size_t)ph;
    sm->scat = calloc(sm->npx * 3, sizeof *sm->scat);
    sm->lamb = calloc(sm->npx * 3, sizeof *sm->lamb);
    sm->hits = calloc(sm->npx, 1);
    return sm->scat && sm->lamb && sm->hits;
}

static void samples_free(samples *sm)
{
    free(sm->scat), free(sm->lamb), free(sm->hits);
    sm->scat = sm->lamb = NULL;
    sm->hits = NULL;
}

/* The frame's exitance per unknown and channel, for exitance_at. */
static int exitance_load(render_ctx *r)
{
    const ohm_solution *sol = ohm_state_solution(r->s);
    int ok = 1;
    for (int c = 0; c < r->channels; ++c) {
        r->exitance[c] = malloc((size_t)(sol->n ? sol->n : 1) * sizeof *r->exitance[c]);
        if (r->exitance[c]) ohm_solution_exitance_frame(r->exitance[c], sol, c, r->frame);
        else ok = 0;
    }
    return ok;
}

/* The scene, the vertex normals and the exitance: what tracing holds. */
static void tracing_free(render_ctx *r)
{
    setups_free(r);
    scene_free(r);
    free(r->vnormal);
    r->vnormal = NULL;
    for (int c = 0; c < 3; ++c) free(r->exitance[c]), r->exitance[c] = NULL;
}

/* The smooth normal at barycentric (u, v) of triangle t, turned to the side of
 * the geometric normal n (which faces the camera). */
static void smooth_normal(const render_ctx *r, size_t t, double u, double v, const double n[3], double ns[3])
{
    const int64_t *ti = r->s->mesh.tris + 3 * t;
    for (int a = 0; a < 3; ++a)
        ns[a] = (1 - u - v) * r->vnormal[3 * ti[0] + a] + u * r->vnormal[3 * ti[1] + a] + v * r->vnormal[3 * ti[2] + a];
    if (!ohm_vec3_normalize(ns)) memcpy(ns, n, 3 * sizeof *ns);
    if (dot3(ns, n) < 0)
        for (int a = 0; a < 3; ++a) ns[a] = -ns[a];
}

/* One camera ray through (X, Y) on the view plane: what it sees is added to
 * pixel px of sm (the no-scattering radiance too when albedo is given). */
static void trace_ray(const render_ctx *r, const camera *cam, double X, double Y, const double *albedo, samples *sm,
                      size_t px)
{
    const double *f = cam->f;
    double o[3];
    for (int a = 0; a < 3; ++a)
        o[a] = cam->centre[a] + X * cam->right[a] + Y * cam->up[a] - (2.0 * cam->radius + 1.0) * f[a];
    struct RTCIntersectContext ctx;
    struct RTCRayHit rh;
    memset(&rh, 0, sizeof rh);
    rh.ray.org_x = (float)o[0];
    rh.ray.org_y = (float)o[1];
    rh.ray.org_z = (float)o[2];
    rh.ray.dir_x = (float)f[0];
    rh.ray.dir_y = (float)f[1];
    rh.ray.dir_z = (float)f[2];
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = INFINITY;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcInitIntersectContext(&ctx);
    rtcIntersect1(r->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return;
    double p[3], n[3] = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
    for (int a = 0; a < 3; ++a) p[a] = o[a] + (double)rh.ray.tfar * f[a];
    if (!ohm_vec3_normalize(n)) return;
    if (dot3(n, f) > 0)
        for (int a = 0; a < 3; ++a) n[a] = -n[a]; /* face the camera */
    double e[3];
    exitance_at(r, p, e);
    for (int c = 0; c < 3; ++c) sm->scat[3 * px + c] += e[c];
    if (albedo) {
        double ns[3], E[3];
        smooth_normal(r, (size_t)rh.hit.primID, rh.hit.u, rh.hit.v, n, ns);
        irradiance_at(r, p, ns, E);
        for (int c = 0; c < 3; ++c) sm->lamb[3 * px + c] += albedo[c] * E[c];
    }
    ++sm->hits[px];
}

/* Every pixel of a pw x ph panel, SUPERSAMPLE^2 rays each on a regular grid. */
static void trace_panel(const render_ctx *r, const camera *cam, int pw, int ph, const double *albedo, samples *sm)
{
    const int S = SUPERSAMPLE;
    for (int y = 0; y < ph; ++y)
        for (int x = 0; x < pw; ++x) {
            size_t px = (size_t)y * pw + x;
            for (int sy = 0; sy < S; ++sy)
                for (int sx = 0; sx < S; ++sx) {
                    double X = (-1.0 + 2.0 * (x + (sx + 0.5) / S) / pw) * cam->hw;
                    double Y = (1.0 - 2.0 * (y + (sy + 0.5) / S) / ph) * cam->hh;
                    trace_ray(r, cam, X, Y, albedo, sm, px);
                }
        }
}

/* The scene, the shading's inputs and the buffers; then every ray of the
 * panel (both panels with compare=1) into sm.  img is allocated here, before
 * tracing, so that a lack of memory shows before the work. */
static int trace_image(samples *sm, float **img, render_ctx *r, const camera *cam, const render_request *q,
                       ohm_error *err)
{
    int rc = scene_build(r, &r->s->mesh, err);
    if (rc) return rc;
    double albedo[3] = {0, 0, 0};
    if (q->compare) {
        rc = setups_init(r, err);
        if (rc) {
            setups_free(r);
            scene_free(r);
            return rc;
        }
        lambert_albedo(r, albedo);
        r->vnormal = vertex_normals(&r->s->mesh);
        if (!r->vnormal) {
            setups_free(r);
            scene_free(r);
            return ohm_fail(err, OHM_ERR_NOMEM, "-render: out of memory for vertex normals");
        }
    }
    int ok = samples_alloc(sm, q->pw, q->ph);
    *img = malloc((size_t)q->W * (size_t)q->H * 3 * sizeof **img);
    ok = exitance_load(r) && ok && *img;
    if (ok) trace_panel(r, cam, q->pw, q->ph, q->compare ? albedo : NULL, sm);
    tracing_free(r);
    if (ok) return OHM_OK;
    samples_free(sm);
    free(*img);
    *img = NULL;
    return ohm_fail(err, OHM_ERR_NOMEM, "-render: out of memory for a %d x %d image", q->W, q->H);
}

/* ---- exposure and tone mapping --------------------------------------------------- */

/* exposure=, else the one that maps the 99th percentile of the brightest
 * channel over the pixels that see the object to 1. */
static int expose(double *exposure, const samples *sm, const ohm_invocation *inv, ohm_log *log, ohm_error *err)
{
    *exposure = 1.0;
    size_t nhit = 0;
    for (size_t i = 0; i < sm->npx; ++i) nhit += sm->hits[i] > 0;
    if (ohm_opt_given(inv, "exposure")) {
        *exposure = ohm_opt_real(inv, "exposure");
    } else if (nhit > 0) {
        double *v = malloc(nhit * sizeof *v);
        if (!v) return ohm_fail(err, OHM_ERR_NOMEM, "-render: out of memory");
        size_t k = 0;
        for (size_t i = 0; i < sm->npx; ++i)
            if (sm->hits[i]) {
                const double *c = sm->scat + 3 * i;
                v[k++] = fmax(c[0], fmax(c[1], c[2])) / sm->hits[i];
            }
        qsort(v, nhit, sizeof *v, cmp_double);
        double p99 = v[(size_t)floor(0.99 * (double)(nhit - 1))];
        free(v);
        if (p99 > 0) *exposure = 1.0 / p99;
        else ohm_log_warn(log, "-render: no light leaves the visible surface: the image is black");
    }
    if (nhit == 0) ohm_log_warn(log, "-render: the object is not in view");
    return OHM_OK;
}

/* Linear RGB, W x H: the scattering panel on the left, the no-scattering one
 * beside it with compare=1; rays that miss are the background. */
static void tone_map(float *img, const render_request *q, const samples *sm, double exposure)
{
    const int S = SUPERSAMPLE, W = q->W, pw = q->pw;
    for (size_t i = 0; i < (size_t)W * q->H * 3; ++i) img[i] = BACKGROUND;
    const double inv_ss = 1.0 / (S * S);
    for (int y = 0; y < q->ph; ++y)
        for (int x = 0; x < pw; ++x) {
            size_t px = (size_t)y * pw + x;
            double bgw = (S * S - sm->hits[px]) * inv_ss * BACKGROUND;
            for (int c = 0; c < 3; ++c) {
                img[3 * ((size_t)y * W + x) + c] = (float)(exposure * sm->scat[3 * px + c] * inv_ss + bgw);
                if (q->compare)
                    img[3 * ((size_t)y * W + pw + x) + c] = (float)(exposure * sm->lamb[3 * px + c] * inv_ss + bgw);
            }
        }
}

/* The image to its file, through a temporary one renamed into place. */
static int write_image(const render_request *q, const float *img, ohm_output_batch *batch, ohm_error *err)
{
    ohm_output out;
    int rc = ohm_output_begin(&out, q->path, batch, err);
    if (rc) return rc;
    rc = ohm_image_write_to(q->path, ohm_output_tmp_path(&out), img, q->W, q->H, 3, err);
    if (rc) ohm_output_abort(&out);
    else rc = ohm_output_commit(&out, err);
    return rc;
}

/* ---- the action ----------------------------------------------------------------- */

void ohm_render_io(const ohm_invocation *inv, ohm_step_io *io)
{
    (void)inv;
    io->needs[0] = (ohm_need){OHM_RES_SOLUTION, 0, "no solution yet: put -solve before it"};
    io->needs[1] = (ohm_need){OHM_RES_MESH, 0, "needs the mesh the solution was computed on"};
}

int ohm_run_render(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    render_request q;
    int rc = read_request(&q, s, inv, err);
    if (rc) return rc;
    double t0 = ohm_now();

    const ohm_solution *sol = ohm_state_solution(s);
    render_ctx r;
    memset(&r, 0, sizeof r);
    r.s = s;
    r.net = &sol->net;
    r.frame = q.frame - 1;
    r.channels = sol->channels;
    camera cam;
    rc = camera_setup(&cam, &r, &q, inv, err);
    if (rc) return rc;
    r.eps = 1e-4 * (cam.radius > 0 ? cam.radius : 1.0);

    samples sm = {0};
    float *img = NULL;
    rc = trace_image(&sm, &img, &r, &cam, &q, err);
    if (rc) return rc;
    double exposure;
    rc = expose(&exposure, &sm, inv, &s->log, err);
    if (!rc) tone_map(img, &q, &sm, exposure);
    samples_free(&sm);
    if (!rc) rc = write_image(&q, img, s->outputs, err);
    free(img);
    if (rc) return rc;
    double t = ohm_now() - t0;
    ohm_log_info(&s->log, "rendered %s: %d x %d%s, frame %d, view %.3g,%.3g,%.3g, exposure %.4g mm^2/W%s, %.2f s",
                 q.path, q.W, q.H, q.compare ? " (scattering | no scattering)" : "", q.frame, cam.f[0], cam.f[1],
                 cam.f[2], exposure, ohm_opt_given(inv, "exposure") ? "" : " (auto)", t);
    ohm_stats_add(&s->stats, "t_render", t);
    return OHM_OK;
}
