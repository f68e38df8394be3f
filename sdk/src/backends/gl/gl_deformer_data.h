// A GL deformer's data and the helpers its files share (gl_deformer.c: one instance and the shared block; gl_batch.c:
// many instances of one mesh; gl_networks.c: f_LP, the guard and f_dec for a batch; gl_program.c: dispatch, compile,
// errors, below the others). Internal to sdk/src/backends/gl/.
#ifndef PLEAT_GL_DEFORMER_DATA_H
#define PLEAT_GL_DEFORMER_DATA_H
#include "kernels/kernels.h"
#include "gl_internal.h"
#include <stdatomic.h>

// body_contact.comp's constants, from kernels.h so that the CPU kernels and the shader cannot drift apart; then the
// pass (posing the body points, their normals from the posed rings, or the push) and, for a batch's programs,
// PLEAT_BATCH.
#define PLEAT_GL_STRING_( x ) #x
#define PLEAT_GL_STRING( x ) PLEAT_GL_STRING_( x )
#define PLEAT_GL_CONTACT_DEFINES                                                                                       \
	"#define PLEAT_MAX_CONTACT_CANDIDATES " PLEAT_GL_STRING( PLEAT_MAX_CONTACT_CANDIDATES ) "\n"                       \
	"#define PLEAT_CONTACT_BLEND_SHARE " PLEAT_GL_STRING( PLEAT_CONTACT_BLEND_SHARE ) "\n"                             \
	"#define PLEAT_CONTACT_BLEND_M " PLEAT_GL_STRING( PLEAT_CONTACT_BLEND_M ) "\n"                                     \
	"#define PLEAT_CONTACT_REACH_NEAR_M " PLEAT_GL_STRING( PLEAT_CONTACT_REACH_NEAR_M ) "\n"                           \
	"#define PLEAT_CONTACT_REACH_FAR_M " PLEAT_GL_STRING( PLEAT_CONTACT_REACH_FAR_M ) "\n"
#define PLEAT_GL_POSE_POINTS_DEFINES PLEAT_GL_CONTACT_DEFINES "#define PLEAT_POSE_POINTS 1\n"
#define PLEAT_GL_POINT_NORMALS_DEFINES PLEAT_GL_CONTACT_DEFINES "#define PLEAT_POSE_POINTS 2\n"
#define PLEAT_GL_BATCH_DEFINES "#define PLEAT_BATCH 1\n"

enum
{
	PLEAT_GL_PROGRAM_BLEND_SHAPES,
	PLEAT_GL_PROGRAM_SKINNING,
	PLEAT_GL_PROGRAM_FACE_NORMALS,
	PLEAT_GL_PROGRAM_NORMALS_GATHER,
	PLEAT_GL_PROGRAM_BODY_POINTS,        // body_contact.comp, PLEAT_POSE_POINTS 1: assets with body points (else 0)
	PLEAT_GL_PROGRAM_BODY_POINT_NORMALS, // body_contact.comp, PLEAT_POSE_POINTS 2: body points with rings (else 0)
	PLEAT_GL_PROGRAM_BODY_CONTACT,       // body_contact.comp, the push: assets with body points (else 0)
	PLEAT_GL_PROGRAM_COUNT
};

// The buffers a deformer keeps once it has led a batch (plGlDeformer_RunBatch): one block per member at each
// per-instance binding; the mesh's own buffers are the deformer's.
typedef struct plGlBatchBuffers
{
	uint32_t capacity;                       // members the buffers hold (0: no batch yet)
	GLuint buffers[PLEAT_GL_BINDING_COUNT];  // per-instance bindings only (0 elsewhere)
	GLuint points_program;                   // body_contact.comp with PLEAT_BATCH 1, posing (body points only)
	GLuint normals_program;                  // body_contact.comp with PLEAT_BATCH 1, ring normals (points with rings)
	GLuint contact_program;                  // body_contact.comp with PLEAT_BATCH 1, the push (body points only)
	GLuint timer_queries[2];                 // networks, deformation (g_plGlTimeBatches; made at first use)
	uint64_t* template_keys;                 // [capacity][2]: the (serial, template generation) each slot holds
	size_t template_keys_bytes;              // as allocated: a reservation that failed in GL keeps capacity 0
	void* staging;                           // [capacity] weights, matrices or contact rows on their way up
	size_t staging_bytes;
} plGlBatchBuffers;

// One layer of a network on the GPU: its transposed weights, bias and NetworkLayer block.
typedef struct plGlNetworkLayerBuffers
{
	GLuint weights, bias, params;
	uint32_t in_count, out_count;
} plGlNetworkLayerBuffers;

// A deformer's networks (made with plGlDeformerDesc.networks; layer_count 0: none) and, once it has led a batch with
// them, the batch's network buffers.
typedef struct plGlNetworks
{
	uint32_t lp_count, dec_count;                               // layers of f_LP, then f_dec, in layers
	plGlNetworkLayerBuffers layers[2 * PLEAT_MAX_LAYERS];
	GLuint guard_params;                                        // NetworkLayer with in_count = L
	GLuint latent_range;                                        // vec4 [L]
	GLuint layer_program, guard_program;                        // mlp_layer.comp, latent_guard.comp
	uint32_t input_count, latent_count, widest;                 // X_c's width, L, the widest hidden layer
	// The batch's (lead only): X_c rows, hidden activations, y, Z, the members block and the finite flags.
	uint32_t capacity;
	GLuint input, ping, pong, y, z, members, finite;
	void* staging; // [capacity] X_c rows, then slots and flags on their way
	size_t staging_bytes;
} plGlNetworks;

// What the deformers of one asset in one context share (plGlDeformerDesc.share): the programs, the mesh's static
// buffers (blend shapes, skinning, faces, adjacency, body points, candidates, rings), the networks' weights and, in
// headless mode, the context itself. Made by the first deformer; the last one to go deletes it.
typedef struct plGlShared
{
	_Atomic uint32_t refcount;
	plGlContext* context; // headless mode: the context every sharing deformer enters; NULL in host-context mode
	GLuint programs[PLEAT_GL_PROGRAM_COUNT];
	GLuint buffers[PLEAT_GL_BINDING_COUNT]; // the static bindings' buffers (plGlBindingIsStatic), 0 elsewhere
	plGlNetworks networks;                  // the static part: layers, guard, programs (no batch buffers)
} plGlShared;

// Non-zero for the bindings whose buffers never change after Create (shared by the deformers that share).
int plGlBindingIsStatic( plGlBinding binding );

struct plGlDeformer
{
	plAllocator allocator;
	plGlDeformerMode mode;
	plGlContext* context; // headless mode only (the shared block's)
	plGlShared* shared;   // never NULL once made
	plGlApi api;

	uint32_t vertex_count;    // N
	uint32_t face_count;      // F
	uint32_t blend_count;     // D
	uint32_t influence_count; // K
	uint32_t joint_count;     // J
	uint32_t anchor_influence_count; // Ka, 0 without body points
	uint32_t point_count;            // P, 0 without body points
	uint32_t candidate_count;        // C (1 for the identity table of a 1.1 asset), 0 without body points
	uint32_t point_ring_count;       // R ring entries per point (asset 1.2, BARG), 0 without rings or body points
	int body_contact;                // the contact passes run (body points present and enabled)
	float body_contact_offset_m;     // the clearance the params buffer holds

	GLuint programs[PLEAT_GL_PROGRAM_COUNT];
	GLuint params_buffer;                    // plGlDeformParams
	GLuint owned[PLEAT_GL_BINDING_COUNT];    // per-deformer buffers it created (0 for static ones and host buffers)
	GLuint bindings[PLEAT_GL_BINDING_COUNT]; // what Run binds at each binding point

	// Conversions on upload and read-backs; staging_bytes = max(16 (N + P), 4 N K, 4 P Ka, 4 N C, 4 P R).
	void* staging;
	size_t staging_bytes;

	uint64_t serial;              // unique per deformer
	uint64_t template_generation; // grows with every shaped-template upload
	plGlBatchBuffers batch;
	plGlNetworks networks;
	uint32_t binding_count; // bindings the deformer uses and saves: PLEAT_GL_BINDING_NETWORK_WEIGHTS without networks

	plGlSavedState saved; // host-context mode: the engine's state during one of our calls
};

// ---- gl_networks.c: f_LP → guard → f_dec for a batch (deformers made with networks) ----

// Checks the networks' description against the deformer's sizes (Create, before any GL).
plResult plGlNetworks_Validate( const plGlNetworksDesc* desc, uint32_t blend_count );
// Compiles the two programs and uploads every layer and the guard's ranges into `into` (a shared block's networks),
// between plGlBegin and plGlEnd.
plResult plGlNetworks_Create( plGlDeformer* deformer, plGlNetworks* into, const plGlNetworksDesc* desc );
// The static part (layers, guard, programs) of a shared block's networks.
void plGlNetworks_DeleteStatic( const plGlApi* api, plGlNetworks* networks );
// A deformer's batch buffers.
void plGlNetworks_DeleteBatch( plGlDeformer* deformer );
void plGlNetworks_FreeHost( plGlDeformer* deformer );
// Uploads the network members' X_c and runs f_LP, the guard and f_dec for them, the decoder writing each one's
// weights into its slot of the batch's weights buffer; the barrier after it lets the blend read them. Returns the
// number of network members (0: nothing ran). Between plGlBegin and plGlEnd, after the batch's inputs are uploaded.
plResult plGlNetworks_Run( plGlDeformer* lead, const plGlBatchMember* members, uint32_t count, uint32_t* out_ran );
// Reads Z_t+1, the finite flags and w back into the network members' outputs.
void plGlNetworks_ReadBack( plGlDeformer* lead, const plGlBatchMember* members, uint32_t count );

// A new shader storage buffer of `bytes` (data NULL: uninitialised), left bound to the generic binding.
GLuint plGlNewStorageBuffer( const plGlApi* api, size_t bytes, const void* data, GLenum usage );
// One dispatch, counted in g_plGlDispatches (tests check that a batch runs one per shader).
void plGlDispatch( const plGlApi* api, GLuint groups_x, GLuint groups_y );
// Makes the deformer's GL usable for one call (headless: our context current; host: checks a context is current and
// saves the engine's state), and undoes it.
plResult plGlBegin( plGlDeformer* deformer );
void plGlEnd( plGlDeformer* deformer );
// Drains the GL error flags; GL_ERROR if any was set.
plResult plGlCheckErrors( const plGlApi* api );
// A compute program from a shader source with `defines` after its #version line; 0 on failure.
GLuint plGlCompileProgram( const plGlApi* api, const char* source, const char* defines );
// xyz rows → vec4 rows with w = w_value (the std430 layout of a vec3 array).
void plGlToVec4( plGlVec4* rows, const float* xyz, uint32_t count, float w_value );
// Rows of the shaped-template buffer per instance: the template, then the P body points.
size_t plGlShapedRows( const plGlDeformer* deformer );
// The passes in order for `instances` rows of workgroups (gl_deformer.c says which).
void plGlRunShaders( const plGlDeformer* deformer, GLuint points_program, GLuint normals_program,
                     GLuint contact_program, uint32_t instances );

#endif
