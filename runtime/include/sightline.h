/* sightline.h: C interface of sightline-runtime (build the crate with `--features ffi`; the
 * library is libsightline_runtime.so / .dylib / sightline_runtime.dll).
 *
 * Conventions: Quake axes (+Z up), units are map units, angles in degrees. Every function that
 * returns int returns SL_OK (0) on success, or an SL_ERR_* code; sl_last_error() then describes
 * the failure for the calling thread. A world may be shared by threads; a scratch is used by one
 * thread at a time. */
#ifndef SIGHTLINE_H
#define SIGHTLINE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

enum {
    SL_OK = 0,
    SL_ERR_NULL = 1,    /* a required pointer was null */
    SL_ERR_IO = 2,      /* the file could not be read */
    SL_ERR_INVALID = 3, /* the level failed to parse or validate */
    SL_ERR_BACKEND = 4, /* unknown backend, or it cannot run on this world */
    SL_ERR_PANIC = 5    /* internal error caught at the boundary */
};

enum {
    SL_BACKEND_PVS = 0,   /* precomputed PVS + frustum walk (default) */
    SL_BACKEND_PORTAL = 1 /* run-time portal traversal (needs portals) */
};

typedef struct SlWorld SlWorld;
typedef struct SlScratch SlScratch;

typedef struct SlCamera {
    float position[3];
    float yaw;    /* 0 = +X, 90 = +Y */
    float pitch;  /* positive looks up */
    float roll;
    float fov_y;  /* vertical field of view, degrees */
    float aspect; /* width / height */
    float near_dist;
    float far_dist;
} SlCamera;

typedef struct SlTrace {
    int32_t hit;         /* 1 when the segment entered solid */
    int32_t start_solid; /* 1 when the start point is in solid */
    float fraction;      /* of the segment travelled (1 when no hit) */
    float point[3];      /* end point, backed off into open space */
    float normal[3];     /* surface normal facing the start (zero when no hit) */
    uint32_t leaf;       /* solid leaf entered (0 when no hit) */
} SlTrace;

/* Message of the last failure on this thread ("" when none); valid until the next failure. */
const char *sl_last_error(void);

/* Load a .slvl or Quake .bsp (a PRT1 NAME.prt beside NAME.bsp or NAME.vis.bsp adds portals). */
int sl_world_load_file(const char *path, SlWorld **out);
/* Load .slvl or .bsp bytes (copied). */
int sl_world_load_bytes(const uint8_t *data, size_t len, SlWorld **out);
void sl_world_free(SlWorld *world);
uint32_t sl_world_num_leaves(const SlWorld *world);

int sl_leaf_at(const SlWorld *world, const float position[3], uint32_t *out_leaf);
int sl_trace(const SlWorld *world, const float from[3], const float to[3], SlTrace *out);

SlScratch *sl_scratch_new(const SlWorld *world);
void sl_scratch_free(SlScratch *scratch);

/* Visible leaves front to back: writes min(count, capacity) leaves, and the full count. */
int sl_visible_leaves(const SlWorld *world, SlScratch *scratch, const SlCamera *camera, int backend,
                      uint32_t *out_leaves, size_t capacity, size_t *out_count);

#ifdef __cplusplus
}
#endif

#endif /* SIGHTLINE_H */
