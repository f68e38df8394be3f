// Internal: the instance, one dressed character, shared by its three files —
//     instance.c         create / destroy, shape and material, getters
//     instance_step.c    plInstance_Step: the paper's equations as a row of jobs, then the commit
//     instance_deform.c  blend shapes → skinning → normals split over the host's workers (CPU path)
// The instance owns the pose history, the latent, the shaped template cache and every buffer a step needs, allocated
// once at creation.
#ifndef PLEAT_INSTANCE_H
#define PLEAT_INSTANCE_H
#include "asset.h"
#include "core.h"
#include "gl_deformer.h"
#include "jobs.h"
#include "ort_backend.h"

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
	int deformed_is_committed; // CPU path: deformed holds T_def of the committed blend weights and current β

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
	float* gl_normals;      // [N][3] GPU modes only: normals read back here (positions into deformed, unused on the
	                        // GPU path) and copied to normals/positions only when the whole step succeeded

	plOrtMlp* ort_lp;
	plOrtMlp* ort_dec;
	plGlDeformer* gl;
} plInstanceData;

// The live instance a handle names (its context's generation included), or NULL.
plInstanceData* plGetInstanceData( plInstance handle );

// CPU path: T_def = shaped template + Σ_j w_j D_j (unless blend is 0: deformed already holds T_def for these weights),
// then skinning with skin_matrices into positions, then normals, split over the context's workers.
// PLEAT_RESULT_INTERNAL_ERROR if a job rejected the spans it was given (a defect of the SDK).
plResult plDeformCpu( plInstanceData* inst, const float* blend_weights, const float* skin_matrices, int blend );
// Normals of inst->positions into inst->normals on the calling thread (face normals, then the gather), for the rest
// pose at creation. PLEAT_RESULT_INTERNAL_ERROR as plDeformCpu.
plResult plNormalsSerial( plInstanceData* inst );

#endif
