// Internal contract between the instance (sdk/src/instance/instance.c) and the GL compute path (sdk/src/backends/gl/).
// The instance runs the MLPs on the CPU (or ONNX Runtime) and hands the GL deformer the D blend weights and the J
// skinning matrices, or, on the GPU backend (PLEAT_MLP_BACKEND_GPU), hands a batch the normalised X_c and the deformer
// runs f_LP, the latent guard and f_dec too (mlp_layer.comp, latent_guard.comp; gl_networks.c); the deformer runs blend_shapes.comp, skinning.comp, face_normals.comp and normals_gather.comp
// (shaders/), the same jobs as blend_shapes.c, skinning.c and normals.c (plFaceNormalsJob, plNormalsGatherJob). Built only with PLEAT_GL; otherwise gl_deformer_stub.c returns
// PLEAT_RESULT_GL_UNAVAILABLE from Create.
#ifndef PLEAT_GL_DEFORMER_H
#define PLEAT_GL_DEFORMER_H
#include "core/allocator.h"
#include "kernels/kernels.h"
#include "pleat/pleat.h"
#include <stdint.h>

typedef struct plGlDeformer plGlDeformer;

typedef enum plGlDeformerMode
{
	// The engine's GL 4.3+ context is current on the calling thread for Create, Run and Destroy. The SDK saves and
	// restores every piece of GL state it touches and never makes a context current.
	PLEAT_GL_DEFORMER_HOST_CONTEXT = 1,
	// The SDK creates its own headless context (EGL device platform with a hardware device, then EGL surfaceless, then
	// OSMesa) and makes it current only inside its own calls, restoring the previously current EGL context afterwards.
	PLEAT_GL_DEFORMER_HEADLESS = 2,
} plGlDeformerMode;

// The two networks, for a deformer that runs them (PLEAT_MLP_BACKEND_GPU). fp32 or fp16 layers (int8 layers are the
// CPU's: Create refuses them); the asset's layers, read once at Create.
typedef struct plGlNetworksDesc
{
	const plLayer* lp;          // [lp_layer_count] f_LP: X_c (normalised) → y
	uint32_t lp_layer_count;
	uint32_t lp_activation;     // PLEAT_ACTIVATION_RELU or _SILU, on every layer but the last
	const plLayer* dec;         // [dec_layer_count] f_dec: Z → w ([D])
	uint32_t dec_layer_count;
	uint32_t dec_activation;
	const float* z_mean;        // [L] the latent guard (latent_guard.c)
	const float* z_std;
	const float* z_min;
	const float* z_max;
} plGlNetworksDesc;

typedef struct plGlDeformerDesc
{
	plGlDeformerMode mode;
	uint32_t vertex_count;    // N
	uint32_t face_count;      // F
	uint32_t blend_count;     // D
	uint32_t influence_count; // K
	uint32_t joint_count;     // J
	const float* shaped_template;       // [N][3] T + G_S(β), metres
	plBlendShapes blend_shapes;         // [D][N][3], fp32, fp16 or int8 (uploaded as plShapeValue's fp32 values)
	const uint16_t* skin_indices;       // [N][K]
	const float* skin_weights;          // [N][K]
	const uint32_t* faces;              // [F][3]
	const uint32_t* adjacency_offsets;  // [N + 1] CSR into adjacency_faces
	const uint32_t* adjacency_faces;    // [3F]
	// Body contact (optional; NULL body_anchors = the asset has none): the P body points of the current β, the asset's
	// point normals and skinning, and each vertex's candidate points (pleat.h BODY CONTACT; body_contact.c).
	const float* body_anchors;              // [P][3]
	const float* body_anchor_normals;       // [P][3]
	const uint16_t* body_anchor_skin_indices; // [P][Ka]
	const float* body_anchor_skin_weights;    // [P][Ka]
	uint32_t body_anchor_influence_count;     // Ka
	uint32_t body_point_count;                // P
	const uint16_t* body_anchor_candidates;   // [N][C], PLEAT_NO_CONTACT_CANDIDATE = empty; NULL: vertex v's point is v
	uint32_t body_anchor_candidate_count;     // C (1 with NULL candidates)
	const uint16_t* body_anchor_ring;         // [P][R] (BARG) or NULL: each point's ring, for the posed body's normal
	uint32_t body_anchor_ring_count;          // R (3..PLEAT_MAX_POINT_RING; 0 with NULL rings)
	// Host-context mode only, optional (0 = the deformer owns its output buffers): GL buffer names the engine renders
	// from; the deformer writes one vec4 per vertex (xyz, w = 1 for positions, 0 for normals).
	uint32_t host_position_buffer;
	uint32_t host_normal_buffer;
	// Optional (NULL = the networks run on the CPU): the networks, which batches then run on the GPU.
	const plGlNetworksDesc* networks;
	// Optional (NULL = none): a live deformer of the same mesh, mode and networks whose programs, static buffers (blend
	// shapes, skinning, faces, adjacency, body points, network weights) and, headless, context this one shares
	// (INVALID_ARGUMENT if the sizes differ). Sharers are called from one thread at a time; in host-context mode they
	// must live in one context or share group. Only the template of β, the weights, matrices and outputs are its own.
	const struct plGlDeformer* share;
	// Headless mode only, optional (NULL = no report): Create writes here, NUL-terminated, which platform, device and
	// renderer the headless context got (or why every route failed), for the instance to log.
	char* report;
	size_t report_size;
} plGlDeformerDesc;

plResult plGlDeformer_Create( const plGlDeformerDesc* desc, const plAllocator* allocator, plGlDeformer** out );
// Called when β changes (the shaped template and, with body anchors, the anchors of β are recomputed on the CPU once,
// then uploaded in one BufferSubData: a GL error leaves both as they were). body_anchors: [P][3], NULL without.
plResult plGlDeformer_SetShapedTemplate( plGlDeformer* deformer, const float* shaped_template, const float* body_anchors );
// Body contact for the following Runs (a deformer made without body anchors ignores it). offset_m: metres, >= 0.
plResult plGlDeformer_SetBodyContact( plGlDeformer* deformer, int enabled, float offset_m );
// blend_weights: [D]; skin_matrices: [J][3][4] row-major (rest space → output space).
// positions / normals: optional [N][3] read-backs (NULL = leave the result on the GPU only).
plResult plGlDeformer_Run( plGlDeformer* deformer, const float* blend_weights, const float* skin_matrices,
						   float* positions, float* normals );
void plGlDeformer_Destroy( plGlDeformer* deformer );

// ---- batches (plStepInstances): one dispatch per shader for many instances of one mesh ----

// The most members one plGlDeformer_RunBatch takes (plStepInstances's largest group, PLEAT_GPU_GROUP_MAX).
#define PLEAT_GL_BATCH_MAX 1024

// One instance of a batch: its own deformer (its mode, host buffers, body-contact setting and shaped-template
// generation) and what plGlDeformer_Run would get for it.
typedef struct plGlBatchMember
{
	plGlDeformer* deformer;       // the instance's own; plGlDeformer_CanBatch( lead, deformer )
	const float* shaped_template; // [N][3] T + G_S(β) of the β its deformer holds (uploaded when that changed)
	const float* body_anchors;    // [P][3] body points of the same β (meshes with body contact; else NULL)
	const float* blend_weights;   // [D]
	const float* skin_matrices;   // [J][3][4]
	float* positions;             // optional [N][3] read-back (NULL = none), as plGlDeformer_Run
	float* normals;               // optional [N][3] read-back
	// Deformers made with networks only: the member's normalised X_c ([input count]) when its networks run this step
	// (NULL: they do not, and blend_weights are its held weights). The batch then runs f_LP → guard → f_dec on the
	// GPU, blends with the w it got, and reads back Z_t+1, w and whether y was all finite (the CPU's checks and commit
	// need them; one small read-back per batch).
	const float* network_input;
	float* latent_out;            // [L] Z_t+1 (network members; required with network_input)
	float* weights_out;           // [D] w (network members; required with network_input; may be blend_weights)
	int* latent_finite_out;       // f_LP's y was all finite (else the member takes the numeric reset)
} plGlBatchMember;

// Non-zero if the deformer was made with networks (they run in batches: plGlDeformer_RunBatch).
int plGlDeformer_HasNetworks( const plGlDeformer* deformer );
// Non-zero if member's instance can run in a batch that lead runs: the same mode, mesh and network sizes. (Host-context
// deformers must also live in the context current for the call, as for Run.)
int plGlDeformer_CanBatch( const plGlDeformer* lead, const plGlDeformer* member );
// Runs count members (1..PLEAT_GL_BATCH_MAX) as plGlDeformer_Run runs each of them, with one dispatch per shader for
// all of them: the lead's context runs blend_shapes → skinning (→ body_contact) → face_normals → normals_gather once,
// with the member in gl_WorkGroupID.y, over per-instance buffers the lead keeps (made at its first batch, grown for a
// larger one; a member's shaped template is uploaded only when the slot last held another). Each member's results
// then go where its own Run puts them: its host vertex buffers (GPU copies) and the read-backs it asks for. The same
// GLSL as Run, so results match per-instance runs (test_gl_batch_matches_single). An error may leave the members'
// GPU outputs partly written, as Run's may; nothing on the CPU side changes.
plResult plGlDeformer_RunBatch( plGlDeformer* lead, const plGlBatchMember* members, uint32_t count );

// Compute dispatches issued by every deformer since the process started (for tests: a batch issues one per shader).
extern _Atomic uint64_t g_plGlDispatches;
// Programs compiled by every deformer since the process started (for tests: a deformer that shares compiles none).
extern _Atomic uint64_t g_plGlProgramsCompiled;
// Benchmarks only (bench/gl_crowd_timing.c): while g_plGlTimeBatches is non-zero, every batch wraps its network
// dispatches and its deformation dispatches in GL_TIME_ELAPSED queries and adds their GPU nanoseconds here. Reading a
// query waits for the GPU, and an engine's own GL_TIME_ELAPSED query must not be active meanwhile: never in a game.
extern _Atomic int g_plGlTimeBatches;
extern _Atomic uint64_t g_plGlNetworkNs, g_plGlDeformNs;

#endif
