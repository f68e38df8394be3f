// Internal: the instance, one dressed character, shared by its four files —
//     instance.c         create / destroy, shape, material and the other settings
//     instance_query.c   the getters (plInstance_Get*)
//     instance_step.c    plInstance_Step: the paper's equations as a row of jobs, then the commit
//     instance_deform.c  blend shapes → skinning → normals split over the host's workers (CPU path)
// The instance owns the pose history, the latent, the shaped template cache and every buffer a step needs, allocated
// once at creation.
#ifndef PLEAT_INSTANCE_H
#define PLEAT_INSTANCE_H
#include "asset/asset.h"
#include "core/core.h"
#include "backends/gl_deformer.h"
#include "jobs/jobs.h"
#include "backends/onnx/ort_backend.h"

#include <stddef.h>
#include <stdint.h>

typedef struct plInstanceData
{
	plContextData* ctx;
	plAssetData* asset;
	plAsset asset_handle;
	void* user_data;

	int32_t joint_map[PLEAT_MAX_JOINTS]; // engine joint per asset joint, −1 = identity
	uint32_t engine_joint_count;

	float beta[PLEAT_MAX_BETAS];       // clamped β
	float material[4];                 // clamped (m, μ, λ, k)
	float material_normalized[4];      // (x − min) / (max − min)
	double rest_joints[PLEAT_MAX_JOINTS * 3]; // J(β)

	plPoseFrame history[2]; // frames t and t−1 (of the network: the frames at its last two updates)
	int history_valid;      // 0: the next step is a first frame
	plPoseFrame next_frame; // scratch for t+1

	double network_interval_s; // 1 / network_rate_hz; 0 = the networks run every step
	double network_pending_s;  // time since the last network update (steps that skipped it)
	double network_lead_s;     // the next update comes this much before its interval is full (< the interval; a scene
	                           // staggering its characters' updates), 0 again after it
	int deformed_is_committed; // CPU path: deformed holds T_def of the committed blend weights and current β

	int body_contact;            // non-zero: the body-contact job runs after skinning (the asset has body points)
	int body_contact_fast;       // with body_contact: the fast contact (PLEAT_BODY_CONTACT_FAST, or a 1.1 asset's)
	float body_contact_offset_m; // its clearance (metres)

	float skin_matrices[PLEAT_MAX_JOINTS * 12];      // last committed step
	float next_skin_matrices[PLEAT_MAX_JOINTS * 12]; // scratch

	// One block, 64-byte aligned sub-buffers.
	void* block;
	size_t block_size;
	float* shaped_template; // [N][3] T + G_S(β)
	float* latent;          // [L] Z_t
	float* next_latent;     // [L]
	float* x;               // [I] X_c, then normalised
	float* y;               // [L] raw f_LP output
	float* blend_weights;   // [D] last committed
	float* next_weights;    // [D]
	float* mlp_scratch;     // [2 · widest]
	uint32_t mlp_scratch_count;
	float* deformed;        // [N][3] T_def
	float* positions;       // [N][3]
	float* normals;         // [N][3]
	float* face_normals;    // [F][4] scratch: unnormalised face normals (x, y, z, 0)
	float* shaped_anchors;  // [2][P][3] assets with body contact only (else NULL): the body points of the committed
	                        // β, then scratch where plInstance_SetShape builds the next ones
	float* posed_points;    // [P][PLEAT_POSED_POINT_FLOATS] assets with body contact only: the body points in the pose
	                        // of the step (plPoseBodyPointsFn), read by the push
	float* shape_weights;   // [D] assets with int8 blend shapes only: the weights the blend kernels take
	                        // (plBlendKernelWeights)
	float* gl_normals;      // [N][3] GPU modes only: normals read back here (positions into deformed, unused on the
	                        // GPU path) and copied to normals/positions only when the whole step succeeded

	plGpuMode gpu_mode;  // the def's (gpu_share must match it)
	int read_back_always; // a scene's GPU instance: its outputs come back to the CPU at every step (plWantsReadBack)
	plMlpBackend mlp_backend;
	plOrtMlp* ort_lp;
	plOrtMlp* ort_dec;
	plGlDeformer* gl;
} plInstanceData;

// The live instance a handle names (its context's generation included), or NULL.
plInstanceData* plGetInstanceData( plInstance handle );
// plGetInstanceData for a public entry point: a handle that names no live instance is logged (INSTANCE_STALE_HANDLE,
// with function, the caller's name) where its context is alive.
plInstanceData* plLookupInstance( plInstance handle, const char* function );
// Logs INSTANCE_STALE_HANDLE: "function: handle (slot, generation) detail". ctx may be NULL (then nothing is logged).
void plLogStaleInstance( const plContextData* ctx, plInstance handle, const char* function, const char* detail );
// Logs that a GPU-mode call of the instance (function: its public name) found no GL context current and changed
// nothing, when r is PLEAT_RESULT_GL_UNAVAILABLE; returns r.
plResult plLogIfNoGlContext( const plInstanceData* inst, plResult r, const char* function );
// ---- instance_deform.c ----

// What one CPU deformation reads and writes. A step deforms its blend into inst->deformed and skins that into the
// instance's outputs; the scene's LBS-only level skins the shaped template into the character's buffers.
typedef struct plDeformSpans
{
	const float* blend_weights; // [D] w, read when blend is set
	const float* skin_matrices; // [J][3][4]
	int blend;                  // first T_def = shaped template + Σ_j w_j D_j into inst->deformed (rest must be it)
	const float* rest;          // [N][3] what skinning reads: inst->deformed, or inst->shaped_template (no deformation)
	float* positions;           // [N][3] skinned, then pushed out of the body
	float* normals;             // [N][3]
	int force_fast_contact;     // the fast contact where the asset allows it (plRunsFastContact; the LBS-only level)
} plDeformSpans;

// The weights the blend kernels take for w ([D]): w itself, or for int8 blend shapes w with the shapes' scales folded
// in (plFoldShapeScales) into inst->shape_weights.
const float* plBlendKernelWeights( plInstanceData* inst, const float* weights );
// CPU path: the blend (if spans->blend), skinning, body contact and normals, split over runner's workers (the
// context's for a lone instance; NULL = all on this thread, as when workers take whole instances). The results do not
// depend on the split. PLEAT_RESULT_INTERNAL_ERROR if a job rejected the spans it was given (a defect of the SDK).
plResult plDeformCpu( plInstanceData* inst, const plDeformSpans* spans, const plTaskRunner* runner );
// Vertex normals of positions into normals ([N][3] each; inst->face_normals is the scratch), the one rule for which
// jobs run: on one thread a single scatter pass over the faces where the scratch holds N sums (F ≥ N), else face
// normals then the gather over the adjacency, split over runner's workers. Every form gives the same bits.
plResult plRunNormals( plInstanceData* inst, const float* positions, float* normals, const plTaskRunner* runner );
// Body contact (instances with inst->body_contact only), in its jobs: the body points [begin, end) posed with
// skin_matrices into inst->posed_points, then (assets with BARG, after all points are posed) the posed body's normals
// at the points [begin, end), then the push of positions ([N][3], skinned with the same matrices;
// inst->positions for a step) for vertices [begin, end), with the instance's candidates and clearance. plDeformCpu runs
// them as separate tasks over the host's workers; plRunBodyContact runs all three, all points and vertices, on the
// calling thread, as plStepInstances does between its batched skinning and normals and the scene's LBS level on its
// own output.
plResult plPoseBodyPoints( plInstanceData* inst, const float* skin_matrices, uint32_t begin, uint32_t end );
plResult plBodyPointNormals( plInstanceData* inst, uint32_t begin, uint32_t end ); // assets with BARG; else nothing
plResult plPushOutOfBody( plInstanceData* inst, float* positions, uint32_t begin, uint32_t end );
plResult plRunBodyContact( plInstanceData* inst, float* positions, const float* skin_matrices, int fast );
// Whether inst's contact is the fast one: its mode says so (body_contact_fast, which already needs an asset that
// allows it), or force_fast (the scene's LBS-only level) where the asset allows it. 0 without contact.
static inline int plRunsFastContact( const plInstanceData* inst, int force_fast )
{
	return inst->body_contact &&
		   ( inst->body_contact_fast || ( force_fast && inst->asset->body_contact_fast_ready ) );
}
// The fast contact (PLEAT_BODY_CONTACT_FAST; body_contact_fast.c) for vertices [begin, end): each vertex's own point
// (the first N rows, plAssetData.body_contact_fast_ready), its turned rest normal. plRunBodyContact with fast (the
// scene's LBS-only characters) or the instance's mode asking for it runs this instead of the three jobs.
plResult plRunFastBodyContact( plInstanceData* inst, float* positions, const float* skin_matrices, uint32_t begin,
							   uint32_t end );
// ---- instance_step.c: the per-instance stages, the single-stream form of every stage of the step ----
// step.c runs them in one stage list for a group of 1..N instances (plInstance_Step is a group of one), with the wide
// forms of the networks, blend and geometry (step_lanes.c) for a crowd, so every path shares each line that decides
// what a step does (pleat.h: batch = single, bit for bit).

// The pose of frame t+1 as the jobs read it: per asset joint, checked and normalised.
typedef struct plStepPose
{
	double joint_quats[PLEAT_MAX_JOINTS][4]; // local rotations (x, y, z, w), identity where the joint map has −1
	double root_rotation[4];                 // Q_root (x, y, z, w); all zero was taken as identity
	double root_translation[3];              // t_root, metres
} plStepPose;

// Checks the step's arguments in the documented order and gathers the pose (changes nothing in the instance).
plResult plValidateStep( const plInstanceData* inst, const plFrameInput* input, const plStepOutput* output,
						 plStepPose* pose );
// Whether the step's outputs are wanted on the CPU: always on the CPU path; in a GPU mode when output names a buffer.
int plWantsReadBack( const plInstanceData* inst, const plStepOutput* output );
// Frame t+1 into next_frame and next_skin_matrices.
plResult plRunForwardKinematics( plInstanceData* inst, const plStepPose* pose, double dt_s, double previous_yaw );
// X_c from next_frame, the history (NULL = a first frame) and latent, normalised, into inst->x.
plResult plAssembleNetworkInput( plInstanceData* inst, const plPoseFrame* frame_t, const plPoseFrame* frame_tm1,
								 const float* latent );
// The latent guard: inst->y (f_LP's output, checked finite by the caller) → next_latent.
plResult plGuardLatent( plInstanceData* inst );
// After plAssembleNetworkInput: f_LP, the finite check of y, the latent guard, f_dec, the finite check of the weights
// and skinning matrices, on the instance's backend (the MLP job or ONNX Runtime). *out_finite = 0 if a check failed.
plResult plRunNetworks( plInstanceData* inst, int* out_finite );
// Whether the deformation blends this step (then T_def is no longer the committed one): after a network update
// always; between updates (the held weights, copied into next_weights here) only when T_def is not the committed one.
int plBeginBlend( plInstanceData* inst, int networks_ran );
// The deformation of next_weights and next_skin_matrices on the instance's own path: the GPU (read-backs into scratch
// when read_back) or plDeformCpu over runner. *out_finite = 0 if a position or normal is not finite (CPU path only:
// the GPU path keeps its outputs on the GPU).
plResult plDeform( plInstanceData* inst, int blend, int read_back, const plTaskRunner* runner, int* out_finite );
// The numeric reset: frame t+1 again as a first frame with a zero latent (splits its work over the context's workers).
plResult plStepFromReset( plInstanceData* inst, const plStepPose* pose, double dt_s, int read_back );
// The commit: history, latent, weights, skinning matrices, and the copies to the caller's output spans.
void plCommit( plInstanceData* inst, int networks_ran, int reset, float dt_s, int read_back, const plStepOutput* output );
// The step's result after its commit (NUMERIC_RESET, CLAMPED or OK), with its log line.
plResult plStepResult( const plInstanceData* inst, int reset, const plNetworkUpdate* update, float dt_s );

#endif
