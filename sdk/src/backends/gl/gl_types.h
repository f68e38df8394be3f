// C twins of the GLSL interface blocks and buffer elements in shaders/*.comp, and the binding points they use.
// The layouts must match byte for byte: every struct has explicit padding and a _Static_assert on its size.
#ifndef PLEAT_GL_TYPES_H
#define PLEAT_GL_TYPES_H
#include <stdint.h>

// std140 uniform block plGlDeformParams (uniform buffer binding 0). Every shader declares it from the start, as far
// as the fields it reads (body_contact.comp declares all of them).
typedef struct plGlDeformParams
{
	uint32_t vertex_count;    // N
	uint32_t blend_count;     // D
	uint32_t influence_count; // K
	uint32_t joint_count;     // J
	uint32_t face_count;      // F
	uint32_t anchor_influence_count; // Ka: body points' skin influences (0: the asset has no body points)
	float body_contact_offset_m;     // body_contact.comp's clearance (metres)
	uint32_t shaped_rows;            // rows of the shaped-template buffer per instance: N, or N + P with body points
	uint32_t point_count;            // P body points (0 without)
	uint32_t candidate_count;        // C candidate points per vertex (1 for the identity table of a 1.1 asset)
	uint32_t point_ring_count;       // R entries of each body point's ring (asset 1.2, BARG; 0 without)
	uint32_t contact_reach;          // 1: the push fades with the nearest candidate's distance (an asset with a
									 // candidate table, BACA), 0: the whole push (a 1.1 asset's identity table)
} plGlDeformParams;
_Static_assert( sizeof( plGlDeformParams ) == 48, "std140 plGlDeformParams is 48 bytes" );

// std430 vec4 element: positions/normals/templates (xyz + w) and one row of a 3×4 skin matrix.
typedef struct plGlVec4
{
	float x, y, z, w;
} plGlVec4;
_Static_assert( sizeof( plGlVec4 ) == 16, "std430 vec4 is 16 bytes" );

// One fp16 blend-shape displacement: x, y, z and a zero pad, read by the shader as two uints (unpackHalf2x16).
typedef struct plGlHalf4
{
	uint16_t x, y, z, pad;
} plGlHalf4;
_Static_assert( sizeof( plGlHalf4 ) == 8, "two std430 uints" );

// Uniform buffer binding of plGlDeformParams.
#define PLEAT_GL_PARAMS_BINDING 0

// Shader storage buffer bindings (the `binding = n` of each buffer block in shaders/*.comp).
typedef enum plGlBinding
{
	PLEAT_GL_BINDING_SHAPED_TEMPLATE = 0,   // vec4 [N] (+ [P] body points of β) blend_shapes.comp, body_contact.comp
	PLEAT_GL_BINDING_BLEND_SHAPES = 1,      // vec4 or plGlHalf4 [D][N]
	PLEAT_GL_BINDING_BLEND_WEIGHTS = 2,     // float [D]
	PLEAT_GL_BINDING_DEFORMED = 3,          // vec4 [N] T_def      blend_shapes.comp → skinning.comp
	PLEAT_GL_BINDING_SKIN_INDICES = 4,      // uint [N][K]         skinning.comp
	PLEAT_GL_BINDING_SKIN_WEIGHTS = 5,      // float [N][K]
	PLEAT_GL_BINDING_SKIN_MATRICES = 6,     // vec4 [J][3]
	PLEAT_GL_BINDING_POSITIONS = 7,         // vec4 [N]            skinning.comp → face_normals.comp
	PLEAT_GL_BINDING_FACES = 8,             // uint [F][3]         face_normals.comp
	PLEAT_GL_BINDING_ADJACENCY_OFFSETS = 9, // uint [N + 1]        normals_gather.comp
	PLEAT_GL_BINDING_ADJACENCY_FACES = 10,  // uint [3F]
	PLEAT_GL_BINDING_NORMALS = 11,          // vec4 [N]
	PLEAT_GL_BINDING_FACE_NORMALS = 12,     // vec4 [F]            face_normals.comp → normals_gather.comp
	PLEAT_GL_BINDING_ANCHOR_NORMALS = 13,   // vec4 [P] rest normals of the body points, body_contact.comp (posing)
	PLEAT_GL_BINDING_ANCHOR_SKIN_INDICES = 14, // uint [P][Ka]
	PLEAT_GL_BINDING_ANCHOR_SKIN_WEIGHTS = 15, // float [P][Ka]
	PLEAT_GL_BINDING_BATCH_CONTACT = 16,    // vec4 [instances] (enabled, offset_m, 0, 0) body_contact.comp, batches only
	PLEAT_GL_BINDING_POSED_POINTS = 17,     // vec4 [P][2] (a, anchorable), (n, usable) body_contact.comp posing → push
	PLEAT_GL_BINDING_CONTACT_CANDIDATES = 18, // uint [N][C] body point indices, >= P = empty slot (push)
	PLEAT_GL_BINDING_POINT_RINGS = 19,      // uint [P][R] each point's ring, then indices >= P (posed normals)
	// The networks on the GPU (gl_networks.c; deformers made with networks only): mlp_layer.comp, latent_guard.comp.
	PLEAT_GL_BINDING_NETWORK_WEIGHTS = 20,  // uint: one layer's W transposed, [in][out] fp32 or [in][(out+1)/2] fp16
	PLEAT_GL_BINDING_NETWORK_BIAS = 21,     // float [out]
	PLEAT_GL_BINDING_NETWORK_LAYER = 22,    // plGlNetworkLayer
	PLEAT_GL_BINDING_NETWORK_INPUT = 23,    // float [members][in]: X_c, a hidden layer's input, y or Z
	PLEAT_GL_BINDING_NETWORK_OUTPUT = 24,   // float [members][out], or the blend weights by slot
	PLEAT_GL_BINDING_NETWORK_MEMBERS = 25,  // plGlNetworkMembers, then uint [members] slots
	PLEAT_GL_BINDING_LATENT_RANGE = 26,     // vec4 [L] (z_mean, z_std, z_min, z_max)
	PLEAT_GL_BINDING_NETWORK_FINITE = 27,   // uint [members]: y all finite (latent_guard.comp → read back)
	PLEAT_GL_BINDING_COUNT = 28,
} plGlBinding;

// std430 NetworkLayer of mlp_layer.comp and latent_guard.comp: one per layer of f_LP and f_dec (and one for the guard,
// in_count = out_count = L), written once when the deformer is made.
typedef struct plGlNetworkLayer
{
	uint32_t in_count, out_count;
	uint32_t activation;     // 0 none (a network's last layer), PLEAT_ACTIVATION_RELU or _SILU
	uint32_t weight_fp16;
	uint32_t output_by_slot; // 1: the decoder's last layer, which writes each member's blend weights at its slot
	uint32_t block_count;
	uint32_t pad0, pad1;
	uint32_t blocks[8][4];   // plLayerBlock rows (row_begin, row_end, col_begin, col_end), PLEAT_MAX_LAYER_BLOCKS
} plGlNetworkLayer;
_Static_assert( sizeof( plGlNetworkLayer ) == 160, "std430 NetworkLayer is 160 bytes" );

// std430 NetworkMembers head: the batch's members that run their networks this step; uint slots[member_count] follow
// (each one's index in the batch, where its blend weights go).
typedef struct plGlNetworkMembers
{
	uint32_t member_count;
	uint32_t pad[3];
} plGlNetworkMembers;
_Static_assert( sizeof( plGlNetworkMembers ) == 16, "the slots start at byte 16" );

// Batches (plGlDeformer_RunBatch): the buffers above marked per instance hold [instances] blocks of the size given
// (shaped template [instances][shaped_rows], weights [instances][D], T_def, positions and normals [instances][N], skin
// matrices [instances][J][3], face normals [instances][F], posed body points [instances][P][2]); gl_WorkGroupID.y of a
// dispatch is the instance. The mesh's own buffers (blend shapes, skinning, faces, adjacency, body points' normals and
// skinning, candidates) are shared by the batch.

// Workgroup size of every shader (layout(local_size_x = 64)); dispatch ceil(N / 64) groups (ceil(F / 64) for
// face_normals.comp, ceil(P / 64) for body_contact.comp's two posing passes).
#define PLEAT_GL_WORKGROUP_SIZE 64u

#endif
