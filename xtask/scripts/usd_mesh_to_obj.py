"""Writes the mesh prim of a USD file as OBJ (positions and polygons, file units).

Used once by `cargo xtask data` for newton's unisex_shirt.usd (binary USD); needs
`pip install usd-core`. Usage: python3 usd_mesh_to_obj.py IN.usd PRIM_PATH OUT.obj
"""
import sys

from pxr import Usd, UsdGeom


def main() -> None:
    src, prim_path, out = sys.argv[1], sys.argv[2], sys.argv[3]
    stage = Usd.Stage.Open(src)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(prim_path))
    points = mesh.GetPointsAttr().Get()
    counts = mesh.GetFaceVertexCountsAttr().Get()
    indices = mesh.GetFaceVertexIndicesAttr().Get()
    up = UsdGeom.GetStageUpAxis(stage)
    units = UsdGeom.GetStageMetersPerUnit(stage)
    with open(out, "w") as f:
        f.write(f"# from {src} {prim_path}; up axis {up}; metres per unit {units}\n")
        for p in points:
            f.write(f"v {p[0]!r} {p[1]!r} {p[2]!r}\n")
        k = 0
        for c in counts:
            f.write("f " + " ".join(str(indices[k + i] + 1) for i in range(c)) + "\n")
            k += c


if __name__ == "__main__":
    main()
