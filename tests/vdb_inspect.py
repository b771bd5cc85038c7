"""Read a .vdb with OpenVDB's own Python module (not ohm's code) and print
what a test asserts on, as JSON; or compare two files grid by grid.

  vdb_inspect.py FILE              -> {"grids": [{name, class, voxel_size, ...}]}
  vdb_inspect.py --same A.vdb B.vdb -> exit 0 when every grid has the same
                                      name, class, transform, active voxels
                                      and values
"""
import json
import sys

import pyopenvdb as vdb


def describe(g):
    lo, hi = g.evalActiveVoxelBoundingBox()
    meta = {}
    for k in g.metadata.keys():
        v = g[k]
        meta[k] = v if isinstance(v, (int, float, str)) else list(v)
    return {
        "name": g.name,
        "class": g.gridClass,
        "voxel_size": list(g.transform.voxelSize()),
        "index_bbox": [list(lo), list(hi)],
        # world extent of the active cells, faces not centres
        "world_min": [c - 0.5 * s for c, s in zip(g.transform.indexToWorld(lo), g.transform.voxelSize())],
        "world_max": [c + 0.5 * s for c, s in zip(g.transform.indexToWorld(hi), g.transform.voxelSize())],
        "origin": list(g.transform.indexToWorld((0, 0, 0))),
        "active": g.activeVoxelCount(),
        "background": g.background,
        "meta": meta,
    }


def voxels(g):
    # voxels and active tiles alike: (min corner, max corner) -> value
    return {(tuple(it.min), tuple(it.max)): it.value for it in g.citerOnValues()}


def main(argv):
    if argv[1] == "--same":
        a, _ = vdb.readAll(argv[2])
        b, _ = vdb.readAll(argv[3])
        if [g.name for g in a] != [g.name for g in b]:
            print("grid names differ", [g.name for g in a], [g.name for g in b])
            return 1
        for ga, gb in zip(a, b):
            da, db = describe(ga), describe(gb)
            for key in ("class", "voxel_size", "index_bbox", "origin", "active", "background"):
                if da[key] != db[key]:
                    print(ga.name, key, "differs:", da[key], db[key])
                    return 1
            if voxels(ga) != voxels(gb):
                print(ga.name, "voxel values differ")
                return 1
        print("same: %d grids" % len(a))
        return 0
    grids, _ = vdb.readAll(argv[1])
    print(json.dumps({"grids": [describe(g) for g in grids]}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
