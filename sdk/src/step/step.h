// Internal: the step as one list of stages for a group of 1..N instances of one asset (docs/architecture.md, "One
// step"). plInstance_Step is a group of one, which takes every stage's single-stream form (the single-instance kernels,
// one instance's work split over the host's workers); plStepInstances (batch.c) forms groups of a crowd, which take
// the wide forms (step_lanes.h) where they have them; the scene's LBS-only level is a group with the networks off.
#ifndef PLEAT_STEP_H
#define PLEAT_STEP_H
#include "instance/instance.h"
#include "kernels/kernels_batch.h"

#include <stdint.h>

typedef struct plStepEntry
{
	plInstanceData* inst;
	const plFrameInput* input;
	const plStepOutput* output;
	float* positions;       // [N][3] where the geometry goes: inst->positions, or (networks off) the caller's buffer
	float* normals;         // [N][3] inst->normals, or the caller's
	int read_back;          // the outputs are wanted on the CPU (plWantsReadBack)
	plNetworkUpdate update; // the network rate decision (networks off: a first frame's, for the forward kinematics' dt)
	plResult result;        // < 0: the instance's error (nothing of it changed); else its result once finished
	int needs_reset;        // a non-finite value appeared: the numeric reset runs for it on the calling thread
	int blend;              // its geometry blends T_def first (not yet blended by a wide blend stage)
} plStepEntry;

typedef struct plStepGroup
{
	plContextData* ctx;
	const plAssetData* asset;
	const plTaskRunner* runner; // the host's workers; NULL: everything on the calling thread (a group inside a task)
	int networks;               // 0: pose and geometry only (the LBS-only level): the shaped template skinned with the
	                            // frame's matrices, the fast contact where the asset has it, nothing committed
	const char* function;       // the public entry point, named in log lines
	plStepEntry* entries;       // [count], at most capacity
	uint32_t count;
	uint32_t capacity;          // PLEAT_BATCH_MAX (1 for a lone step), or a GPU group's PLEAT_GPU_GROUP_MAX
	// Filled by plRunStepGroup: the wide forms' kernels (a group of more than one, where the context has them), else
	// NULL and every stage takes its single-stream form; and the members of the stage that runs.
	const plBatchKernels* lanes;
	uint32_t member_count;
	uint32_t* members;              // [capacity] indices into entries
	plInstanceData** member_insts;  // [capacity] their instances
	// A GPU group's GL batch members and flags ([capacity], plGeometryGpu), NULL: the stack's (PLEAT_BATCH_MAX).
	plGlBatchMember* gl_members;
	int* gl_flags;
	uint32_t inline_members[PLEAT_BATCH_MAX];             // members and member_insts of an ordinary group
	plInstanceData* inline_member_insts[PLEAT_BATCH_MAX];
} plStepGroup;

// An empty group over the caller's entries (room for PLEAT_BATCH_MAX unless it steps one instance).
void plStepGroup_Init( plStepGroup* g, plContextData* ctx, const plAssetData* asset, plStepEntry* entries,
					   int networks, const plTaskRunner* runner, const char* function );
// An empty group of up to PLEAT_GPU_GROUP_MAX instances with everything in a scratch block of PLEAT_GPU_GROUP_FLOATS
// floats (64-byte aligned); *out_indices: [PLEAT_GPU_GROUP_MAX] of the caller's, from the same block.
void plStepGroup_InitGpu( plStepGroup* g, plContextData* ctx, const plAssetData* asset, void* block,
						  const plTaskRunner* runner, const char* function, uint32_t** out_indices );
// Appends an instance of the group's asset with its input and output (output NULL: none; networks off: always NULL).
plStepEntry* plStepGroup_Add( plStepGroup* g, plInstanceData* inst, const plFrameInput* input,
							  const plStepOutput* output );
// The stages, in order, for every entry: ① prepare (validation, rate decision, forward kinematics, X_c) → ② networks
// (f_LP, latent guard, f_dec, with their finite checks) → ③ blend → ④ geometry (skinning, body contact, normals, the
// finite check) and the commit → ⑤ numeric resets. GPU-mode groups deform and commit on the GPU at ④. Every entry's
// result lands in its result.
void plRunStepGroup( plStepGroup* g );

#endif
