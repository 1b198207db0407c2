"""Motion files written from joint positions: ``bvh`` (BVH, as the page's src/export/bvh.ts) and ``glb`` (binary glTF)."""
