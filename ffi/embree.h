/* bindgen input: the installed Embree's public API. build.rs defines RAYLINK_EMBREE_MAJOR
 * after finding which Embree is present, so bindings always match the installed headers
 * (struct layouts differ with Embree's build configuration). */
#if RAYLINK_EMBREE_MAJOR == 4
#include <embree4/rtcore.h>
#else
#include <embree3/rtcore.h>
#endif
