// The control block of fuzz_asset_semantic: the first 64 bytes of every input choose the host hooks, the instance def
// and the calls (tests/c/fuzz_asset_semantic.c); fuzz_asset_seed writes seeds with a few chosen control blocks.
#ifndef PLEAT_FUZZ_CONTROL_H
#define PLEAT_FUZZ_CONTROL_H
#include <stdint.h>

enum
{
	PLEAT_FUZZ_FORCE_SCALAR = 1u << 0,
	PLEAT_FUZZ_LOAD_FROM_FILE = 1u << 1,
	PLEAT_FUZZ_IN_PLACE = 1u << 2,
	PLEAT_FUZZ_DEFER_TASKS = 1u << 3,
	PLEAT_FUZZ_CHECK_DETERMINISM = 1u << 4,
	PLEAT_FUZZ_ONNXRUNTIME = 1u << 5,
	PLEAT_FUZZ_BAD_INPUT_PROBES = 1u << 6,
	PLEAT_FUZZ_REVERSE_RANGES = 1u << 7,
};
enum
{
	PLEAT_FUZZ2_ZERO_ROOT_ROTATION = 1u << 0,
	PLEAT_FUZZ2_OFF_UNIT_QUATS = 1u << 1,
	PLEAT_FUZZ2_INITIAL_SHAPE = 1u << 2,
	PLEAT_FUZZ2_DESTROY_IN_USE = 1u << 3,
};

typedef struct plFuzzControl
{
	uint8_t flags;           // 0: PLEAT_FUZZ_*
	uint8_t workers;         // 1: 1 + workers % 4
	uint8_t joint_map_mode;  // 2: % 5 (none, -1 entries, reversed into a larger skeleton, by name, invalid)
	uint8_t extra_joints;    // 3: % 8 engine joints beyond the asset's (reversed map)
	uint8_t output_mode;     // 4: % 6 (none, planar, interleaved, stride 16, normals stride 32, too small)
	uint8_t step_count;      // 5: 1 + step_count % 6
	uint8_t setter_steps;    // 6: bit s: call a setter before step s
	uint8_t setter_kinds;    // 7: 2 bits per step (s % 4): shape, material, network rate, reset
	uint8_t network_rate;    // 8: index into s_rates
	uint8_t dt;              // 9: index into s_dts (varies per step)
	uint8_t fail_allocation; // 10: 1..32 = the allocation that fails; otherwise none
	uint8_t beta_count;      // 11: % (B + 2): B + 1 asks for too many
	int8_t beta[16];         // 12: β = beta / 16
	uint8_t material[4];     // 28: fraction of the asset's range, (material - 28) / 200
	uint8_t pose[16];        // 32: joint angles and axes
	uint8_t root[4];         // 48: root velocity and yaw
	uint8_t input_stride;    // 52: joint stride 16 + 4 · (input_stride % 5) bytes
	uint8_t flags2;          // 53: PLEAT_FUZZ2_*
	uint8_t reserved[10];    // 54
} plFuzzControl;
_Static_assert( sizeof( plFuzzControl ) == 64, "control block layout" );

#define PLEAT_FUZZ_CONTROL_SIZE 64u

#endif
