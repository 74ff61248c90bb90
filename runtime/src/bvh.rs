//! Bounding volume hierarchy over triangles for ray casting (work in progress).
