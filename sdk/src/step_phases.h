// Internal: per-phase timing of plInstance_Step, for the benchmark only. The shipped library is compiled without
// PLEAT_STEP_PHASES, so PLEAT_STEP_PHASE() is empty there; bench/CMakeLists.txt builds a second copy of the library
// with it (pleat_phases) for pleat_bench_phases. Each mark adds the time since the previous mark to the named phase.
// One instance stepped by one thread (the phase totals are plain globals).
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
	PLEAT_PHASE_FACE_NORMALS, // per-face normals (0 on one thread: the scatter pass below does both)
	PLEAT_PHASE_GATHER,       // per-vertex normals (gather + normalise; on one thread the whole normals scatter)
	PLEAT_PHASE_GUARDS,       // non-finite scans of y, weights, matrices, positions, normals
	PLEAT_PHASE_COMMIT,       // commit of history/latent/weights and copies to the caller's outputs
	PLEAT_PHASE_COUNT
} plStepPhase;

#if defined( PLEAT_STEP_PHASES )
extern double g_plStepPhaseUs[PLEAT_PHASE_COUNT]; // accumulated µs per phase since the last plStepPhaseReset
extern int g_plStepPhaseClock;                    // a clockid_t; CLOCK_MONOTONIC by default
void plStepPhaseReset( void );
void plStepPhaseStart( void );
void plStepPhaseMark( plStepPhase phase );
#define PLEAT_STEP_PHASE_START() plStepPhaseStart()
#define PLEAT_STEP_PHASE( phase ) plStepPhaseMark( phase )
#else
#define PLEAT_STEP_PHASE_START() ( (void)0 )
#define PLEAT_STEP_PHASE( phase ) ( (void)0 )
#endif

#endif
