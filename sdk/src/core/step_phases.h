// Internal: per-phase timing of plInstance_Step and of plStepInstances, for the benchmark only. The shipped library is
// compiled without PLEAT_STEP_PHASES, so the marks are empty there; bench/CMakeLists.txt builds a second copy of the
// library with it (pleat_phases) for pleat_bench_phases and pleat_bench_crowd_phases. Each mark adds the time since
// the previous mark of its kind to the named phase. One caller thread (the phase totals are plain globals); a batch's
// phases are that thread's wall time, the work of any helper workers included.
#ifndef PLEAT_STEP_PHASES_H
#define PLEAT_STEP_PHASES_H

typedef enum plStepPhase
{
	PLEAT_PHASE_VALIDATE,     // argument checks, pose gather, quaternion lengths, dt
	PLEAT_PHASE_FK,           // forward kinematics and skinning matrices
	PLEAT_PHASE_INPUT,        // X_c assembly and normalisation
	PLEAT_PHASE_LP,           // f_LP
	PLEAT_PHASE_DEC,          // latent guard + f_dec
	PLEAT_PHASE_BLEND,        // blend shapes: T + G_S(β) + Σ_j w_j D_j
	PLEAT_PHASE_SKIN,         // linear blend skinning
	PLEAT_PHASE_CONTACT,      // body contact: the body points posed, their ring normals, the push (0 without contact)
	PLEAT_PHASE_FACE_NORMALS, // per-face normals (0 on one thread: the scatter pass below does both)
	PLEAT_PHASE_GATHER,       // per-vertex normals (gather + normalise; on one thread the whole normals scatter)
	PLEAT_PHASE_GUARDS,       // non-finite scans of y, weights, matrices, positions, normals
	PLEAT_PHASE_COMMIT,       // commit of history/latent/weights and copies to the caller's outputs
	PLEAT_PHASE_COUNT
} plStepPhase;

// The stages of a wide step group in plStepInstances (step.c plRunStepGroup; a group of one is timed as the single
// step).
typedef enum plBatchPhase
{
	PLEAT_BATCH_PHASE_PREPARE,  // per instance: validation, FK, X_c (plPrepareEntry)
	PLEAT_BATCH_PHASE_NETWORKS, // f_LP and f_dec for the group, with their guards
	PLEAT_BATCH_PHASE_BLEND,    // blend shapes for the group
	PLEAT_BATCH_PHASE_GEOMETRY, // skinning, body contact, normals, finite scans and commits (GPU modes: the deformation)
	PLEAT_BATCH_PHASE_FINISH,   // numeric resets (the finite scans and commits run inside the geometry)
	PLEAT_BATCH_PHASE_COUNT
} plBatchPhase;

#if defined( PLEAT_STEP_PHASES )
extern double g_plStepPhaseUs[PLEAT_PHASE_COUNT];        // accumulated µs per phase since the last plStepPhaseReset
extern double g_plBatchPhaseUs[PLEAT_BATCH_PHASE_COUNT]; // the same for batches (plBatchPhaseReset)
extern int g_plStepPhaseClock;                           // a clockid_t; CLOCK_MONOTONIC by default
void plStepPhaseReset( void );
void plStepPhaseStart( void );
void plStepPhaseMark( plStepPhase phase );
void plBatchPhaseReset( void );
void plBatchPhaseStart( void );
void plBatchPhaseMark( plBatchPhase phase );
#define PLEAT_STEP_PHASE_START() plStepPhaseStart()
#define PLEAT_STEP_PHASE( phase ) plStepPhaseMark( phase )
#define PLEAT_BATCH_PHASE_START() plBatchPhaseStart()
#define PLEAT_BATCH_PHASE( phase ) plBatchPhaseMark( phase )
#else
#define PLEAT_STEP_PHASE_START() ( (void)0 )
#define PLEAT_STEP_PHASE( phase ) ( (void)0 )
#define PLEAT_BATCH_PHASE_START() ( (void)0 )
#define PLEAT_BATCH_PHASE( phase ) ( (void)0 )
#endif

#endif
