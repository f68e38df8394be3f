// Shared by the GL tests and the GL timing program: a procedural garment-like mesh at the shipped size (a 4,424-vertex
// tube skinned to a 24-joint chain), a smooth motion, a double-precision reference of the deformation (the paper's
// equations written out directly, independent of sdk/src), an EGL surfaceless context the test owns (to play the
// engine in host-context mode) and a counting allocator.
#ifndef PLEAT_TEST_GL_SUPPORT_H
#define PLEAT_TEST_GL_SUPPORT_H
#include "allocator.h"
#include "pleat/pleat.h"
#include <stddef.h>
#include <stdint.h>

typedef struct plTestMesh
{
	uint32_t vertex_count, face_count, blend_count, influence_count, joint_count;
	float* shaped_template;      // [N][3]
	float* blend_shapes;         // [D][N][3]
	uint16_t* blend_shapes_fp16; // [D][N][3], the fp32 shapes rounded to half
	float* blend_shapes_rounded; // [D][N][3], blend_shapes_fp16 widened back (the reference for fp16 runs)
	uint16_t* skin_indices;      // [N][K]
	float* skin_weights;         // [N][K]
	uint32_t* faces;             // [F][3]
	uint32_t* adjacency_offsets; // [N + 1]
	uint32_t* adjacency_faces;   // [3F]
	float* joint_rest;           // [J][3] rest joint locations (a chain along +Y)
} plTestMesh;

// rings × segments vertices (rings · segments = 4,424 for the shipped size: 79 × 56), D blend shapes of a few cm.
void plTestMesh_Build( plTestMesh* mesh, uint32_t rings, uint32_t segments, uint32_t blend_count, uint32_t seed );
void plTestMesh_Free( plTestMesh* mesh );

// Frame f of a smooth motion: blend_weights [D] and skin_matrices [J][3][4] (rest → world, forward kinematics of the
// chain with bending joints, a moving root).
void plTestMotion_Frame( const plTestMesh* mesh, uint32_t frame, float* blend_weights, float* skin_matrices );

// The deformation in double: T_def = template + Σ w_j D_j; LBS; area-weighted normals over the adjacency.
// blend_shapes selects fp32 shapes or their fp16-rounded twin. positions/normals: [N][3].
void plTestReference_Deform( const plTestMesh* mesh, const float* blend_shapes, const float* blend_weights,
							 const float* skin_matrices, double* positions, double* normals );

// Largest |a - b| over count values.
double plTestMaxAbsDiff( const float* a, const double* b, size_t count );

// An EGL surfaceless desktop GL 4.3 core context, as an engine would have. Returns 0 (and a zeroed egl) if none can be
// made.
typedef struct plTestEglContext
{
	void* display;
	void* context;
} plTestEglContext;
// Frame `frame` of a swinging pose with a walking, turning root, phase_frames frames ahead (a crowd's instances each at
// their own phase): joint k swings by amplitude · sin(2t + 0.5k) rad about a horizontal axis turned 0.7k, the root walks
// 1.2 m/s along z, sways 0.3 m in x and turns by 0.4 sin(0.7t); t = (frame + phase_frames) / 30 s, dt 1/30 s.
// rotations: [joint_count][4], what input->joint_rotations points to.
void plTestMotion_WalkPose( uint32_t frame, float phase_frames, float amplitude, uint32_t joint_count, float* rotations,
							plFrameInput* input );
int plTestEgl_Create( plTestEglContext* egl );
int plTestEgl_MakeCurrent( const plTestEglContext* egl );
void plTestEgl_Release( const plTestEglContext* egl );
void plTestEgl_Destroy( plTestEglContext* egl );
#if defined( CMOCKA_H_ )
// Skips the calling cmocka test where plTestEgl_Create could make no context (egl->context NULL).
static inline void plTestEgl_Require( const plTestEglContext* egl )
{
	if ( egl->context == NULL )
	{
		print_message( "SKIP: no EGL surfaceless desktop GL 4.3 core context can be created on this machine\n" );
		skip();
	}
}
#endif

// An allocator over malloc that counts live bytes and checks the size passed to free.
typedef struct plTestAllocatorState
{
	long long live_bytes;
	long long allocation_count;
	int size_mismatch;
} plTestAllocatorState;
plAllocator plTestAllocator( plTestAllocatorState* state );

double plTestNowSeconds( void );

#endif
