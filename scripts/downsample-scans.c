/* downsample-scans.c — how samples/walnut_64x48x57_uint16.raw.gz and
 * samples/ch2_2mm.nii.gz were made from the full-resolution volumes (2x2x2
 * box average, rounded to the input type; an odd last slice is dropped).
 *   cc -O2 -I/usr/include/nifti scripts/downsample-scans.c -o /tmp/ds \
 *      -lnifti2 -lznz -lz -lm
 *   /tmp/ds walnut IN.raw.gz 128 96 114 OUT.raw     (uint16 little-endian)
 *   /tmp/ds nifti  IN.nii.gz OUT.nii.gz
 * The NIfTI header keeps its meaning: dims halved, pixdim doubled, and both
 * sform and qform become M * [2 0 0 0.5; 0 2 0 0.5; 0 0 2 0.5] so every new
 * voxel centre lands on the centre of the 8 voxels it averages. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include <nifti2_io.h>

static double get(const nifti_image *n, size_t i)
{
    switch (n->datatype) {
    case NIFTI_TYPE_UINT8: return ((uint8_t *)n->data)[i];
    case NIFTI_TYPE_INT16: return ((int16_t *)n->data)[i];
    case NIFTI_TYPE_UINT16: return ((uint16_t *)n->data)[i];
    case NIFTI_TYPE_INT32: return ((int32_t *)n->data)[i];
    case NIFTI_TYPE_FLOAT32: return ((float *)n->data)[i];
    case NIFTI_TYPE_FLOAT64: return ((double *)n->data)[i];
    default: fprintf(stderr, "unsupported datatype\n"); exit(1);
    }
}

static void put(nifti_image *n, size_t i, double v)
{
    int integer = n->datatype != NIFTI_TYPE_FLOAT32 && n->datatype != NIFTI_TYPE_FLOAT64;
    if (integer) v = floor(v + 0.5);
    switch (n->datatype) {
    case NIFTI_TYPE_UINT8: ((uint8_t *)n->data)[i] = (uint8_t)v; break;
    case NIFTI_TYPE_INT16: ((int16_t *)n->data)[i] = (int16_t)v; break;
    case NIFTI_TYPE_UINT16: ((uint16_t *)n->data)[i] = (uint16_t)v; break;
    case NIFTI_TYPE_INT32: ((int32_t *)n->data)[i] = (int32_t)v; break;
    case NIFTI_TYPE_FLOAT32: ((float *)n->data)[i] = (float)v; break;
    default: ((double *)n->data)[i] = v; break;
    }
}

static nifti_dmat44 halve(nifti_dmat44 m)
{
    nifti_dmat44 s;
    memset(&s, 0, sizeof s);
    for (int a = 0; a < 3; ++a) {
        s.m[a][a] = 2;
        s.m[a][3] = 0.5;
    }
    s.m[3][3] = 1;
    return nifti_dmat44_mul(m, s);
}

int main(int argc, char **argv)
{
    if (argc == 7 && strcmp(argv[1], "walnut") == 0) {
        size_t nx = (size_t)atoi(argv[3]), ny = (size_t)atoi(argv[4]), nz = (size_t)atoi(argv[5]);
        uint16_t *in = malloc(nx * ny * nz * 2);
        gzFile f = gzopen(argv[2], "rb");
        if (!f || gzread(f, in, (unsigned)(nx * ny * nz * 2)) != (int)(nx * ny * nz * 2)) return 1;
        gzclose(f);
        size_t mx = nx / 2, my = ny / 2, mz = nz / 2;
        uint16_t *out = malloc(mx * my * mz * 2);
        for (size_t k = 0; k < mz; ++k)
            for (size_t j = 0; j < my; ++j)
                for (size_t i = 0; i < mx; ++i) {
                    double s = 0;
                    for (int c = 0; c < 8; ++c)
                        s += in[((2 * k + (c >> 2 & 1)) * ny + 2 * j + (c >> 1 & 1)) * nx + 2 * i + (c & 1)];
                    out[(k * my + j) * mx + i] = (uint16_t)floor(s / 8 + 0.5);
                }
        FILE *o = fopen(argv[6], "wb");
        fwrite(out, 2, mx * my * mz, o);
        fclose(o);
        return 0;
    }
    if (argc == 4 && strcmp(argv[1], "nifti") == 0) {
        nifti_image *n = nifti_image_read(argv[2], 1);
        if (!n) return 1;
        int64_t nx = n->nx, ny = n->ny, nz = n->nz;
        int64_t dims[8] = {3, nx / 2, ny / 2, nz / 2, 1, 1, 1, 1};
        nifti_image *o = nifti_make_new_nim(dims, n->datatype, 1);
        for (int64_t k = 0; k < dims[3]; ++k)
            for (int64_t j = 0; j < dims[2]; ++j)
                for (int64_t i = 0; i < dims[1]; ++i) {
                    double s = 0;
                    for (int c = 0; c < 8; ++c)
                        s += get(n, (size_t)(((2 * k + (c >> 2 & 1)) * ny + 2 * j + (c >> 1 & 1)) * nx + 2 * i + (c & 1)));
                    put(o, (size_t)((k * dims[2] + j) * dims[1] + i), s / 8);
                }
        o->scl_slope = n->scl_slope;
        o->scl_inter = n->scl_inter;
        o->xyz_units = n->xyz_units;
        o->cal_min = n->cal_min;
        o->cal_max = n->cal_max;
        memcpy(o->descrip, n->descrip, sizeof o->descrip);
        o->sform_code = n->sform_code;
        o->qform_code = n->qform_code;
        o->sto_xyz = halve(n->sto_xyz);
        o->sto_ijk = nifti_dmat44_inverse(o->sto_xyz);
        o->qto_xyz = halve(n->qto_xyz);
        o->qto_ijk = nifti_dmat44_inverse(o->qto_xyz);
        double dx, dy, dz;
        nifti_dmat44_to_quatern(o->qto_xyz, &o->quatern_b, &o->quatern_c, &o->quatern_d, &o->qoffset_x,
                                &o->qoffset_y, &o->qoffset_z, &dx, &dy, &dz, &o->qfac);
        o->dx = o->pixdim[1] = dx;
        o->dy = o->pixdim[2] = dy;
        o->dz = o->pixdim[3] = dz;
        if (nifti_set_filenames(o, argv[3], 0, 1)) return 1;
        nifti_image_write(o);
        nifti_image_free(o);
        nifti_image_free(n);
        return 0;
    }
    fprintf(stderr, "usage: see the comment at the top\n");
    return 2;
}
