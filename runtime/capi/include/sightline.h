/* sightline.h: C interface of sightline-runtime. The library is the crate sightline-capi
 * (`cargo build --release -p sightline-capi`: libsightline_capi.so / .dylib / .a, installed as
 * libsightline with SONAME libsightline.so.0 and pkg-config file sightline.pc; see
 * runtime/capi/src/lib.rs).
 *
 * Conventions: Quake axes (+Z up), units are map units, angles in degrees. Every function that
 * returns int returns SL_OK (0) on success, or an SL_ERR_* code; sl_last_error() then describes
 * the failure for the calling thread. A world may be shared by threads; a scratch is used by one
 * thread at a time.
 *
 * Buffer protocol (functions taking `out, capacity, out_count`): at most `capacity` items are
 * written to `out` and the full count to `*out_count`; call with NULL/0 first to get the count.
 * Index spaces: leaves 0..sl_world_num_leaves, clusters 0..sl_world_num_clusters, faces
 * 0..sl_world_num_faces (a .bsp's own face indices), textures 0..sl_world_num_textures, models
 * 0..sl_world_num_models (model 0 is the world); an index out of range gives SL_ERR_RANGE. */
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
    SL_ERR_PANIC = 5,   /* internal error caught at the boundary */
    SL_ERR_RANGE = 6    /* an index (leaf, cluster, face, texture, model) out of range */
};

/* Leaf contents (Quake's codes), from sl_leaf_contents. */
enum {
    SL_CONTENTS_EMPTY = -1,
    SL_CONTENTS_SOLID = -2, /* also every point outside the world */
    SL_CONTENTS_WATER = -3,
    SL_CONTENTS_SLIME = -4,
    SL_CONTENTS_LAVA = -5,
    SL_CONTENTS_SKY = -6
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

/* A face: its plane and draw data. Texture coordinates in texels: s = s[0..3] . p + s[3],
 * t = t[0..3] . p + t[3]; divide by sl_texture_size for normalised ones. */
typedef struct SlFace {
    float normal[3];       /* unit, towards the side the face is seen from */
    float dist;            /* normal . p for points on the face */
    uint32_t texture;      /* texture index */
    uint32_t num_vertices; /* see sl_face_vertices */
    uint32_t first_vertex; /* its vertices in sl_world_vertices: first_vertex..+num_vertices */
    int32_t has_draw;      /* 0: no texture projection (s, t, flags zero, styles 255, light -1) */
    float s[4];
    float t[4];
    uint32_t flags;        /* Quake texinfo flags (bit 0: sky or liquid, not light-mapped) */
    uint8_t styles[4];     /* light styles; 255 ends the list */
    int32_t light_offset;  /* byte offset in the source BSP's lighting lump; -1 for none */
} SlFace;

/* A brush model: bounds as compiled, its faces first_face..first_face + num_faces, and the
   origin of the entity whose "model" is "*N" (where the engine places it; zero when none). */
typedef struct SlModel {
    float mins[3];
    float maxs[3];
    uint32_t first_face;
    uint32_t num_faces;
    float origin[3];
} SlModel;

/* The crate version, "MAJOR.MINOR.PATCH" (static). */
const char *sl_version(void);

/* Message of the last failure on this thread ("" when none); valid until the next failure. */
const char *sl_last_error(void);

/* Load a .slvl or Quake .bsp (a PRT1 NAME.prt beside NAME.bsp or NAME.vis.bsp adds portals).
   Only a regular file is read (symlinks followed): a folder, FIFO or device is SL_ERR_IO. */
int sl_world_load_file(const char *path, SlWorld **out);
/* Load .slvl or .bsp bytes (copied). */
int sl_world_load_bytes(const uint8_t *data, size_t len, SlWorld **out);
void sl_world_free(SlWorld *world);
/* Counts (0 for a null world). */
uint32_t sl_world_num_leaves(const SlWorld *world);
uint32_t sl_world_num_clusters(const SlWorld *world);
uint32_t sl_world_num_faces(const SlWorld *world);
uint32_t sl_world_num_textures(const SlWorld *world);
uint32_t sl_world_num_models(const SlWorld *world);
/* 1 when the level carries a PVS; 0 when it has none (an unvised map: every cluster sees every
 * other, PVS culling culls nothing; the load succeeds either way) or for a null world. */
int sl_world_has_pvs(const SlWorld *world);
/* Entity text (Quake .map syntax without brushes), owned by the world; NULL for a null world. */
const char *sl_world_entities(const SlWorld *world);

/* The leaf holding a point. Every point has one: a point in solid or outside the world gets a
 * solid leaf (sl_leaf_contents gives SL_CONTENTS_SOLID). */
int sl_leaf_at(const SlWorld *world, const float position[3], uint32_t *out_leaf);
/* Contents code of a leaf (SL_CONTENTS_*). */
int sl_leaf_contents(const SlWorld *world, uint32_t leaf, int32_t *out_contents);
/* Cluster of a leaf, or -1 for a leaf without one (solid). */
int sl_leaf_cluster(const SlWorld *world, uint32_t leaf, int32_t *out_cluster);
/* Bounds of a leaf as the level stores them. */
int sl_leaf_bounds(const SlWorld *world, uint32_t leaf, float out_mins[3], float out_maxs[3]);

/* PVS / PHS row of a cluster as (num_clusters + 63) / 64 words: cluster j is set when bit j % 64
 * (least significant first) of word j / 64 is; bits past the last cluster are clear. Buffer
 * protocol. Without vis data every bit is set. The first sl_phs_row call may compute the PHS. */
int sl_pvs_row(const SlWorld *world, uint32_t cluster, uint64_t *out_words, size_t capacity,
               size_t *out_count);
int sl_phs_row(const SlWorld *world, uint32_t cluster, uint64_t *out_words, size_t capacity,
               size_t *out_count);

/* Open leaves an axis-aligned box touches (conservative within 1/32 unit), each once, in tree
 * order. Buffer protocol. */
int sl_leaves_touching(const SlWorld *world, const float mins[3], const float maxs[3],
                       uint32_t *out_leaves, size_t capacity, size_t *out_count);
/* *out_visible = 1 when the box may be visible from the eye through the PVS (an eye in solid
 * sees everything), else 0. */
int sl_box_potentially_visible(const SlWorld *world, const float eye[3], const float mins[3],
                               const float maxs[3], int32_t *out_visible);
/* Drop, in place, the faces whose plane faces away from the eye by more than 1/32 unit; keeps
 * order and faces out of range; *out_count = number kept. */
int sl_cull_back_faces(const SlWorld *world, const float eye[3], uint32_t *faces, size_t count,
                       size_t *out_count);

int sl_face(const SlWorld *world, uint32_t face, SlFace *out);
/* Vertices of a face as x, y, z triples (3 * capacity floats), clockwise seen from the front.
 * Buffer protocol, counted in vertices. */
int sl_face_vertices(const SlWorld *world, uint32_t face, float *out_xyz, size_t capacity,
                     size_t *out_count);
/* Every face's vertices in one array (x, y, z triples; a face's are num_vertices from its
 * first_vertex), for one vertex buffer. Buffer protocol, counted in vertices. */
int sl_world_vertices(const SlWorld *world, float *out_xyz, size_t capacity, size_t *out_count);
/* Texture name, owned by the world ("" for a texture missing from a BSP); NULL when out of
 * range (sl_last_error says why). */
const char *sl_texture_name(const SlWorld *world, uint32_t texture);
/* Texture size in texels; 0 x 0 when the level does not size its textures. */
int sl_texture_size(const SlWorld *world, uint32_t texture, uint32_t *out_width,
                    uint32_t *out_height);
int sl_model(const SlWorld *world, uint32_t model, SlModel *out);
/* Faces of a cluster's world leaves, each once, ascending. Buffer protocol. */
int sl_cluster_faces(const SlWorld *world, uint32_t cluster, uint32_t *out_faces, size_t capacity,
                     size_t *out_count);
int sl_trace(const SlWorld *world, const float from[3], const float to[3], SlTrace *out);

SlScratch *sl_scratch_new(const SlWorld *world);
void sl_scratch_free(SlScratch *scratch);

/* Visible leaves front to back: writes min(count, capacity) leaves, and the full count. */
int sl_visible_leaves(const SlWorld *world, SlScratch *scratch, const SlCamera *camera, int backend,
                      uint32_t *out_leaves, size_t capacity, size_t *out_count);
/* Visible faces, each once, nearest leaf first; back faces (the eye more than 1/32 unit behind
 * the plane) left out by the walk when cull_back_faces is non-zero. Buffer protocol. */
int sl_visible_faces(const SlWorld *world, SlScratch *scratch, const SlCamera *camera, int backend,
                     int cull_back_faces, uint32_t *out_faces, size_t capacity, size_t *out_count);

#ifdef __cplusplus
}
#endif

#endif /* SIGHTLINE_H */
