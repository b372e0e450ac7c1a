"""The mesh path: OBBs and OBBTrees over triangle meshes, the exact triangle tests and
predicates, the exact contact report of intersecting triangles, the contact manifolds that
dynamics takes from it, and the world narrow phase over many body pairs."""
