/* scene.h — the built-in scenes' building blocks, shared by the validation
 * against exact diffusion references (validate.c) and against Monte Carlo
 * transport (validate_transport.c). */
#ifndef OHM_SCENE_H
#define OHM_SCENE_H

#include "physics/light.h"
#include "physics/material.h"
#include "base/ohm_error.h"
#include "grid/voxelize.h"

/* A box of nx x ny x nz cells of size h, one outside cell around it; the box's
 * low corner is at world 0, so cell (i,j,k) (1-based inside) has its centre at
 * ((i-1/2) h, (j-1/2) h, (k-1/2) h).  No distance field: face normals are used. */
int ohm_scene_box(ohm_voxel_grid *g, int nx, int ny, int nz, double h, ohm_error *err);

/* One grey channel of sigma_a, sigma_s' (1/mm) at the validation index 1.3. */
ohm_material ohm_scene_grey(double sigma_a, double sigma_s);

/* A grey directional light of 1 W/mm^2 along the unit direction dir. */
ohm_light ohm_scene_directional(const double dir[3]);

/* A grey pencil beam of 1 W from pos along the unit direction dir. */
ohm_light ohm_scene_pencil(const double pos[3], const double dir[3]);

#endif
