//! Wavefront OBJ + MTL meshes, through tobj.
