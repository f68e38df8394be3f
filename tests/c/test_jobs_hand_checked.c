// Hand-checkable cases for each job and the pipeline: every expected value below is derived on paper in the comment
// next to it, not taken from the code's own output.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "jobs.h"
#include "test_common.h"

#define PI_F 3.14159265358979f

// A test asset with zero network weights, zero blend shapes and no β (its output is the skinned template), an
// instance on it, and a 30 Hz frame of identity joint rotations with zero root translation.
typedef struct plSkinningOnly
{
	plTestRig rig;
	const plTestAsset* model; // rig.model
	plInstance inst;
	float quats[64 * 4];
	plFrameInput in; // joint_rotations = quats
} plSkinningOnly;

// influence_count: influences per vertex (0: the default).
static void plSkinningOnly_Init( plSkinningOnly* s, uint32_t influence_count )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.weight_scale = 0.0f;
	p.blend_scale = 0.0f;
	p.beta_count = 0;
	if ( influence_count != 0 )
	{
		p.influence_count = influence_count;
	}
	assert_int_equal( plTestRig_Create( &s->rig, &p, NULL ), PLEAT_RESULT_OK );
	s->model = s->rig.model;
	assert_int_equal( plTestRig_Instance( &s->rig, &s->inst ), PLEAT_RESULT_OK );
	memset( s->quats, 0, sizeof( s->quats ) );
	for ( uint32_t j = 0; j < s->rig.model->J; ++j )
	{
		s->quats[j * 4 + 3] = 1.0f;
	}
	memset( &s->in, 0, sizeof( s->in ) );
	s->in.joint_rotations = s->quats;
	s->in.joint_count = s->rig.model->J;
	s->in.dt_s = 1.0f / 30.0f;
}

// Zero network weights and zero blend shapes, identity pose: the output is the template (+ root translation),
// exactly: every skinning matrix is [I | t] and the skin weights of a vertex sum to 1 (1 − f/2 + f/2, exact for
// these dyadic fractions up to one rounding, hence the 1e-6 tolerance).
static void test_identity_pose_and_zero_weights_give_template( void** state )
{
	(void)state;
	plSkinningOnly s;
	plSkinningOnly_Init( &s, 0 );
	s.in.root_translation = ( plVec3 ){ 1.0f, 2.0f, 3.0f };
	for ( int step = 0; step < 3; ++step )
	{
		assert_int_equal( plInstance_Step( s.inst, &s.in, NULL ), PLEAT_RESULT_OK );
	}
	const float *positions, *normals;
	uint32_t count;
	assert_int_equal( plInstance_GetPositions( s.inst, &positions, &count ), PLEAT_RESULT_OK );
	assert_int_equal( count, s.model->N );
	assert_int_equal( plInstance_GetNormals( s.inst, &normals, NULL ), PLEAT_RESULT_OK );
	for ( uint32_t v = 0; v < s.model->N; ++v )
	{
		assert_float_equal( positions[v * 3 + 0], s.model->template_positions[v * 3 + 0] + 1.0f, 1e-6 );
		assert_float_equal( positions[v * 3 + 1], s.model->template_positions[v * 3 + 1] + 2.0f, 1e-6 );
		assert_float_equal( positions[v * 3 + 2], s.model->template_positions[v * 3 + 2] + 3.0f, 1e-6 );
		// The sheet lies in z = 0.1 with counter-clockwise triangles seen from +Z: normal +Z.
		assert_float_equal( normals[v * 3 + 0], 0.0f, 1e-6 );
		assert_float_equal( normals[v * 3 + 1], 0.0f, 1e-6 );
		assert_float_equal( normals[v * 3 + 2], 1.0f, 1e-6 );
	}
	float latent[64];
	assert_int_equal( plInstance_GetLatent( s.inst, latent, 64 ), PLEAT_RESULT_OK );
	for ( uint32_t i = 0; i < s.model->L; ++i )
	{
		assert_float_equal( latent[i], 0.0f, 0.0 );
	}
	plTestRig_Free( &s.rig );
}

// One influence per vertex; joint 2 (rest position (0, 0.5, 0)) rotated 90° about +Z. Vertices bound to joints 0 and 1
// stay; vertices bound to joints 2.. turn about (0, 0.5, 0): (x, y, z) → (−(y − 0.5), x + 0.5, z).
static void test_rotating_one_joint_90_degrees_moves_its_vertices( void** state )
{
	(void)state;
	plSkinningOnly s;
	plSkinningOnly_Init( &s, 1 );
	s.quats[2 * 4 + 2] = sinf( PI_F / 4.0f );
	s.quats[2 * 4 + 3] = cosf( PI_F / 4.0f );
	assert_int_equal( plInstance_Step( s.inst, &s.in, NULL ), PLEAT_RESULT_OK );
	const float* positions;
	assert_int_equal( plInstance_GetPositions( s.inst, &positions, NULL ), PLEAT_RESULT_OK );
	int moved = 0, stayed = 0;
	for ( uint32_t v = 0; v < s.model->N; ++v )
	{
		const float* x = s.model->template_positions + v * 3;
		float ex = x[0], ey = x[1], ez = x[2];
		if ( s.model->skin_indices[v] >= 2 )
		{
			ex = -( x[1] - 0.5f );
			ey = x[0] + 0.5f;
			moved++;
		}
		else
		{
			stayed++;
		}
		assert_float_equal( positions[v * 3 + 0], ex, 1e-5 );
		assert_float_equal( positions[v * 3 + 1], ey, 1e-5 );
		assert_float_equal( positions[v * 3 + 2], ez, 1e-5 );
	}
	assert_true( moved > 0 && stayed > 0 );
	float m[64 * 12];
	assert_int_equal( plInstance_GetSkinMatrices( s.inst, m, s.model->J ), PLEAT_RESULT_OK );
	// M_2 = T(J_2) · Rz(90°) · T(−J_2): rotation rows (0 −1 0), (1 0 0), (0 0 1); translation Rz·(−J_2) + J_2 = (0.5, 0.5, 0).
	const float expected[12] = { 0, -1, 0, 0.5f, 1, 0, 0, 0.5f, 0, 0, 1, 0 };
	for ( int e = 0; e < 12; ++e )
	{
		assert_float_equal( m[2 * 12 + e], expected[e], 1e-6 );
	}
	assert_int_equal( plInstance_GetSkinMatrices( s.inst, m, s.model->J - 1 ), PLEAT_RESULT_BUFFER_TOO_SMALL );
	plTestRig_Free( &s.rig );
}

// The normals of positions through both algorithms (jobs.h): face normals + gather into gathered, scatter into
// scattered. Both must succeed.
static void plRunNormals( const float* positions, uint32_t n, const uint32_t* faces, uint32_t f,
						  const uint32_t* offsets, const uint32_t* adjacency, float* face_normals, float* gathered,
						  float* scattered, float* sums4 )
{
	plFaceNormalsJob face_job = { plMakeConstSpan( positions, n, 12 ), faces, f, face_normals, 0, f, NULL };
	plNormalsGatherJob gather = { face_normals, f, offsets, adjacency, plMakeSpan( gathered, n, 12 ), 0, n, NULL };
	plNormalsScatterJob scatter = { plMakeConstSpan( positions, n, 12 ), faces, f, plMakeSpan( scattered, n, 12 ),
									sums4, n, NULL };
	assert_int_equal( plFaceNormalsJob_Run( &face_job ), PLEAT_RESULT_OK );
	assert_int_equal( plNormalsGatherJob_Run( &gather ), PLEAT_RESULT_OK );
	assert_int_equal( plNormalsScatterJob_Run( &scatter ), PLEAT_RESULT_OK );
}

// Normals of a flat quad (two CCW triangles in the XY plane) are +Z; on a "roof" the shared vertices get the
// area-weighted average (values below). Face normals + gather and the scatter give the same bits.
static void test_normals_of_flat_quad_and_area_weighting( void** state )
{
	(void)state;
	// Quad: v0 (0,0,0) v1 (1,0,0) v2 (1,1,0) v3 (0,1,0); faces (0,1,2) and (0,2,3).
	float positions[4 * 3] = { 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0 };
	uint32_t faces[6] = { 0, 1, 2, 0, 2, 3 };
	uint32_t offsets[5] = { 0, 2, 3, 5, 6 };
	uint32_t adjacency[6] = { 0, 1, 0, 0, 1, 1 };
	_Alignas( 16 ) float face_normals[2 * 4], sums4[4 * 4];
	float normals[4 * 3], scattered[4 * 3];
	plRunNormals( positions, 4, faces, 2, offsets, adjacency, face_normals, normals, scattered, sums4 );
	for ( int v = 0; v < 4; ++v )
	{
		assert_float_equal( normals[v * 3 + 0], 0.0f, 0.0 );
		assert_float_equal( normals[v * 3 + 1], 0.0f, 0.0 );
		assert_float_equal( normals[v * 3 + 2], 1.0f, 0.0 );
	}
	assert_memory_equal( scattered, normals, sizeof( normals ) );
	// Roof: lift v3 to (0, 1, 1). Face 0 cross = (1,0,0)×(1,1,0) = (0,0,1). Face 1 cross = (1,1,0)×(0,1,1) = (1,−1,1).
	// v0 and v2 touch both: sum (1,−1,2), normalised (1,−1,2)/√6. v1: (0,0,1). v3: (1,−1,1)/√3.
	positions[3 * 3 + 2] = 1.0f;
	plRunNormals( positions, 4, faces, 2, offsets, adjacency, face_normals, normals, scattered, sums4 );
	assert_float_equal( face_normals[4], 1.0f, 0 ); // face 1: (1, −1, 1, 0)
	assert_float_equal( face_normals[5], -1.0f, 0 );
	assert_float_equal( face_normals[6], 1.0f, 0 );
	assert_float_equal( face_normals[7], 0.0f, 0 );
	float s6 = 1.0f / sqrtf( 6.0f ), s3 = 1.0f / sqrtf( 3.0f );
	const float expected[12] = { s6, -s6, 2 * s6, 0, 0, 1, s6, -s6, 2 * s6, s3, -s3, s3 };
	for ( int i = 0; i < 12; ++i )
	{
		assert_float_equal( normals[i], expected[i], 1e-6 );
	}
	assert_memory_equal( scattered, normals, sizeof( normals ) );
	// A degenerate vertex (all faces zero area) gets a zero normal, not NaN.
	float flat_line[4 * 3] = { 0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0 };
	plRunNormals( flat_line, 4, faces, 2, offsets, adjacency, face_normals, normals, scattered, sums4 );
	for ( int i = 0; i < 12; ++i )
	{
		assert_float_equal( normals[i], 0.0f, 0.0 );
		assert_float_equal( scattered[i], 0.0f, 0.0 );
	}

	// Invalid inputs, one per row: each job's Validate says no and its Run changes nothing.
	plFaceNormalsJob face_job = { plMakeConstSpan( positions, 4, 12 ), faces, 2, face_normals, 0, 2, NULL };
	plFaceNormalsJob bad_face[3] = { face_job, face_job, face_job };
	bad_face[0].face_end = 3;          // range beyond the faces
	bad_face[1].face_normals = NULL;   // no output
	bad_face[2].positions.bytes = 12;  // span too short for 4 vertices
	plNormalsGatherJob gather = { face_normals, 2, offsets, adjacency, plMakeSpan( normals, 4, 12 ), 0, 4, NULL };
	plNormalsGatherJob bad_gather[4] = { gather, gather, gather, gather };
	bad_gather[0].face_normals = NULL;               // no face normals
	bad_gather[1].vertex_end = 5;                    // range beyond the output
	bad_gather[2].adjacency_offsets = NULL;          // no adjacency
	bad_gather[3].normals = plMakeSpan( normals, 4, 8 ); // stride smaller than a vertex
	plNormalsScatterJob scatter = { plMakeConstSpan( positions, 4, 12 ), faces, 2, plMakeSpan( normals, 4, 12 ),
									sums4, 4, NULL };
	plNormalsScatterJob bad_scatter[3] = { scatter, scatter, scatter };
	bad_scatter[0].sums4_count = 3;                       // scratch shorter than N
	bad_scatter[1].sums4 = sums4 + 1;                     // scratch not 16-byte aligned
	bad_scatter[2].normals = plMakeSpan( normals, 3, 12 ); // output count differs from the positions'
	float before[12];
	memcpy( before, normals, sizeof( before ) );
	for ( int i = 0; i < 3; ++i )
	{
		assert_false( plFaceNormalsJob_Validate( &bad_face[i] ) );
		assert_int_equal( plFaceNormalsJob_Run( &bad_face[i] ), PLEAT_RESULT_INVALID_ARGUMENT );
		assert_false( plNormalsScatterJob_Validate( &bad_scatter[i] ) );
		assert_int_equal( plNormalsScatterJob_Run( &bad_scatter[i] ), PLEAT_RESULT_INVALID_ARGUMENT );
	}
	for ( int i = 0; i < 4; ++i )
	{
		assert_false( plNormalsGatherJob_Validate( &bad_gather[i] ) );
		assert_int_equal( plNormalsGatherJob_Run( &bad_gather[i] ), PLEAT_RESULT_INVALID_ARGUMENT );
	}
	assert_memory_equal( before, normals, sizeof( before ) );
}

// Skinning writes through a strided (interleaved) output span and leaves the bytes between vertices alone.
static void test_skinning_writes_interleaved_span( void** state )
{
	(void)state;
	float rest[2 * 3] = { 1, 2, 3, -1, 0, 2 };
	uint16_t idx[2 * 2] = { 0, 1, 1, 0 };
	float w[2 * 2] = { 0.25f, 0.75f, 1.0f, 0.0f };
	// M_0 = identity + translation (1, 0, 0); M_1 = 2 · identity (scale), no translation.
	float m[2 * 12] = { 1, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0 };
	float out[2 * 8];
	for ( int i = 0; i < 16; ++i )
	{
		out[i] = -7.0f;
	}
	plSkinningJob job = { plMakeConstSpan( rest, 2, 12 ), idx, w, 2, m, 2, plMakeSpan( out, 2, 32 ), 0, 2, NULL, NULL };
	assert_int_equal( plSkinningJob_Run( &job ), PLEAT_RESULT_OK );
	// v0: 0.25 · ((1,2,3) + (1,0,0)) + 0.75 · (2,4,6) = (0.5,0.5,0.75) + (1.5,3,4.5) = (2, 3.5, 5.25).
	assert_float_equal( out[0], 2.0f, 1e-6 );
	assert_float_equal( out[1], 3.5f, 1e-6 );
	assert_float_equal( out[2], 5.25f, 1e-6 );
	// v1: 1.0 · M_1 · (−1, 0, 2) = (−2, 0, 4).
	assert_float_equal( out[8], -2.0f, 1e-6 );
	assert_float_equal( out[9], 0.0f, 1e-6 );
	assert_float_equal( out[10], 4.0f, 1e-6 );
	for ( int i = 3; i < 8; ++i )
	{
		assert_float_equal( out[i], -7.0f, 0.0 );
		assert_float_equal( out[8 + i], -7.0f, 0.0 );
	}
}

// A table of invalid job inputs: each is rejected by _Validate and _Run returns INVALID_ARGUMENT.
static void test_jobs_reject_invalid_spans( void** state )
{
	(void)state;
	float rest[2 * 3] = { 0 };
	uint16_t idx[2] = { 0, 0 };
	float w[2] = { 1, 1 };
	float m[12] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0 };
	float out[2 * 3];
	plSkinningJob good = { plMakeConstSpan( rest, 2, 12 ), idx, w, 1, m, 1, plMakeSpan( out, 2, 12 ), 0, 2, NULL, NULL };
	assert_true( plSkinningJob_Validate( &good ) );
	plSkinningJob bad[7];
	for ( int i = 0; i < 7; ++i )
	{
		bad[i] = good;
	}
	bad[0].positions.ptr = NULL;                    // null input
	bad[1].output.stride_bytes = 8;                 // stride smaller than a vertex
	bad[2].output.bytes = 12;                       // span too short for 2 vertices
	bad[3].vertex_end = 3;                          // range beyond the span
	bad[4].influence_count = 0;                     // no influences
	bad[5].output.ptr = (void*)( (uint8_t*)out + 1 ); // misaligned floats
	bad[6].output.ptr = (void*)rest;                // aliases the input
	for ( int i = 0; i < 7; ++i )
	{
		assert_false( plSkinningJob_Validate( &bad[i] ) );
		assert_int_equal( plSkinningJob_Run( &bad[i] ), PLEAT_RESULT_INVALID_ARGUMENT );
	}
	assert_int_equal( plFaceNormalsJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plNormalsGatherJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plNormalsScatterJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plMlpJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plBlendShapesJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plInputAssemblyJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plForwardKinematicsJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
}

// A 2 → 2 → 1 MLP with hand weights. Hidden = act(W0 x + b0), out = W1 h + b1 (linear).
static void test_mlp_small_network_by_hand( void** state )
{
	(void)state;
	float w0[4] = { 1, -1, 2, 0.5f }, b0[2] = { 0.5f, -3 };
	float w1[2] = { 2, -1 }, b1[1] = { 0.25f };
	plLayer layers[2] = { { .weight = w0, .bias = b0, .in_count = 2, .out_count = 2 },
						  { .weight = w1, .bias = b1, .in_count = 2, .out_count = 1 } };
	float x[2] = { 1, 2 }, y[1], scratch[4];
	plKernels kernels;
	plChooseKernels( &kernels, PLEAT_KERNEL_SET_SCALAR );
	plMlpJob job = { layers, 2, PLEAT_ACTIVATION_RELU, plMakeConstSpan( x, 2, 4 ), plMakeSpan( y, 1, 4 ),
					 plMakeSpan( scratch, 4, 4 ), &kernels, NULL };
	assert_int_equal( plMlpJob_Run( &job ), PLEAT_RESULT_OK );
	// pre = (1 − 2 + 0.5, 2 + 1 − 3) = (−0.5, 0); ReLU → (0, 0); out = 0.25.
	assert_float_equal( y[0], 0.25f, 1e-7 );
	x[0] = 3;
	// pre = (3 − 2 + 0.5, 6 + 1 − 3) = (1.5, 4); out = 3 − 4 + 0.25 = −0.75.
	assert_int_equal( plMlpJob_Run( &job ), PLEAT_RESULT_OK );
	assert_float_equal( y[0], -0.75f, 1e-6 );
	job.activation = PLEAT_ACTIVATION_SILU;
	// SiLU(1.5) = 1.5 / (1 + e^−1.5), SiLU(4) = 4 / (1 + e^−4).
	double h0 = 1.5 / ( 1.0 + exp( -1.5 ) ), h1 = 4.0 / ( 1.0 + exp( -4.0 ) );
	assert_int_equal( plMlpJob_Run( &job ), PLEAT_RESULT_OK );
	assert_float_equal( y[0], (float)( 2 * h0 - h1 + 0.25 ), 1e-5 );
}

// X_c from hand-built frames (docs/inputs.md): L = 1, Jin = 1 (joint 1), B = 1.
// Frame t+1: pelvis at (1, 0, 0), yaw 90° (heading +X), joint 1 at (1, 1, 0), dt 0.1.
// Frame t and t−1: pelvis at (0, 0, 0), yaw 0, joint 1 at (0, 1, 0) and (0, 1, 0), dt 0.2.
static void test_input_assembly_against_hand_values( void** state )
{
	(void)state;
	plPoseFrame f[3];
	memset( f, 0, sizeof( f ) );
	for ( int i = 0; i < 3; ++i )
	{
		for ( int j = 0; j < 2; ++j )
		{
			f[i].local_rotations[j][0] = f[i].local_rotations[j][4] = f[i].local_rotations[j][8] = 1.0;
		}
		f[i].joint_positions[1][1] = 1.0;
		f[i].dt_s = 0.2;
	}
	// t+1: pelvis rotation = Ry(90°) = [[0,0,1],[0,1,0],[−1,0,0]], joint 1's local rotation = Rx(90°).
	double ry[9] = { 0, 0, 1, 0, 1, 0, -1, 0, 0 };
	memcpy( f[0].pelvis_rotation, ry, sizeof( ry ) );
	f[0].yaw = PI_F / 2.0;
	f[0].dt_s = 0.1;
	f[0].joint_positions[0][0] = 1.0;
	f[0].joint_positions[1][0] = 1.0;
	double rx[9] = { 1, 0, 0, 0, 0, -1, 0, 1, 0 };
	memcpy( f[0].local_rotations[1], rx, sizeof( rx ) );
	for ( int i = 1; i < 3; ++i )
	{
		f[i].pelvis_rotation[0] = f[i].pelvis_rotation[4] = f[i].pelvis_rotation[8] = 1.0;
	}
	float latent[1] = { 0.5f }, beta[1] = { -1.5f }, material[4] = { 0.1f, 0.2f, 0.3f, 0.4f };
	uint32_t input_joints[1] = { 1 };
	uint32_t I = (uint32_t)plInputCountFormula( 1, 1, 1 ); // 1 + 8 + 3·12 + 9 + 1 + 4 = 59
	assert_int_equal( I, 59 );
	float x[59];
	plInputAssemblyJob job = { { &f[0], &f[1], &f[2] }, latent, 1, input_joints, 1, beta, 1, material,
							   plMakeSpan( x, 59, 4 ) };
	assert_int_equal( plInputAssemblyJob_Run( &job ), PLEAT_RESULT_OK );
	const float tol = 1e-5f;
	assert_float_equal( x[0], 0.5f, 0 );
	// v_t: (1,0,0)/0.1 = (10,0,0) world; in heading +X that is forward = local +Z → (0, 0, 10); ω = (π/2)/0.1.
	assert_float_equal( x[1], 0.0f, tol );
	assert_float_equal( x[2], 0.0f, tol );
	assert_float_equal( x[3], 10.0f, tol );
	assert_float_equal( x[4], 15.707963f, 1e-4 );
	// v_{t−1}: no motion, no turn.
	for ( int i = 5; i < 9; ++i )
	{
		assert_float_equal( x[i], 0.0f, tol );
	}
	// Rotations of t+1: joint 1 Rx(90°) 6D = (R00, R10, R20, R01, R11, R21) = (1, 0, 0, 0, 0, 1).
	const float rx6[6] = { 1, 0, 0, 0, 0, 1 };
	for ( int i = 0; i < 6; ++i )
	{
		assert_float_equal( x[9 + i], rx6[i], tol );
	}
	// Pelvis tilt of t+1: yaw⁻¹ · P = identity → (1, 0, 0, 0, 1, 0). Frames t and t−1 are identity too.
	const float id6[6] = { 1, 0, 0, 0, 1, 0 };
	for ( int fi = 0; fi < 3; ++fi )
	{
		for ( int i = 0; i < 6; ++i )
		{
			assert_float_equal( x[9 + fi * 12 + 6 + i], id6[i], tol );
			if ( fi > 0 )
			{
				assert_float_equal( x[9 + fi * 12 + i], id6[i], tol );
			}
		}
	}
	// Positions: joint 1 is 1 m above the pelvis in every frame → (0, 1, 0) in any heading frame.
	for ( int fi = 0; fi < 3; ++fi )
	{
		assert_float_equal( x[45 + fi * 3 + 0], 0.0f, tol );
		assert_float_equal( x[45 + fi * 3 + 1], 1.0f, tol );
		assert_float_equal( x[45 + fi * 3 + 2], 0.0f, tol );
	}
	assert_float_equal( x[54], -1.5f, 0 );
	for ( int i = 0; i < 4; ++i )
	{
		assert_float_equal( x[55 + i], material[i], 0 );
	}
	// A span one float short is rejected.
	job.output = plMakeSpan( x, 58, 4 );
	assert_int_equal( plInputAssemblyJob_Run( &job ), PLEAT_RESULT_INVALID_ARGUMENT );
}

// Forward kinematics of a 3-joint chain along +Y (joints at y = 0, 1, 2) with joint 1 turned 90° about +Z and the
// root moved to (5, 0, 0): joint 2 ends at (5 − 1, 1, 0); pelvis yaw of an identity root is 0.
static void test_forward_kinematics_chain( void** state )
{
	(void)state;
	int32_t parents[3] = { -1, 0, 1 };
	double rest[9] = { 0, 0, 0, 0, 1, 0, 0, 2, 0 };
	double root_t[3] = { 5, 0, 0 };
	double root_r[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
	plPoseFrame frame;
	memset( &frame, 0, sizeof( frame ) );
	double q_id[4] = { 0, 0, 0, 1 };
	double q_z90[4] = { 0, 0, sin( PI_F / 4 ), cos( PI_F / 4 ) };
	plQuatToMatrix( q_id, frame.local_rotations[0] );
	plQuatToMatrix( q_z90, frame.local_rotations[1] );
	plQuatToMatrix( q_id, frame.local_rotations[2] );
	float skin[3 * 12];
	plForwardKinematicsJob job = { parents, 3, rest, root_t, root_r, 0.0, 0.1, &frame, skin };
	assert_int_equal( plForwardKinematicsJob_Run( &job ), PLEAT_RESULT_OK );
	assert_float_equal( frame.joint_positions[1][0], 5.0, 1e-9 );
	assert_float_equal( frame.joint_positions[1][1], 1.0, 1e-9 );
	assert_float_equal( frame.joint_positions[2][0], 4.0, 1e-6 );
	assert_float_equal( frame.joint_positions[2][1], 1.0, 1e-6 );
	assert_float_equal( frame.yaw, 0.0, 1e-12 );
	// Skin matrix of joint 0: identity rotation, translation (5, 0, 0).
	assert_float_equal( skin[3], 5.0f, 1e-6 );
	// A parent after its child is rejected.
	parents[2] = 2;
	assert_int_equal( plForwardKinematicsJob_Run( &job ), PLEAT_RESULT_INVALID_ARGUMENT );
}

// Shape blend over 2 vertices, B = 2: T = ((1, 2, 3), (0, 0, 0)), G_S[0] = (1, 1, 1) and G_S[1] = (0.5, 0, 0) for both
// vertices, β = (2, −4): vertex 0 → (1, 2, 3) + (2, 2, 2) + (−2, 0, 0) = (1, 4, 5), vertex 1 → (0, 2, 2).
// J(β) of the same arrays read as two joints is the same sum, in double.
static void test_shape_blend_and_shaped_joints_by_hand( void** state )
{
	(void)state;
	float t[6] = { 1, 2, 3, 0, 0, 0 };
	float g[12] = { 1, 1, 1, 1, 1, 1, 0.5f, 0, 0, 0.5f, 0, 0 };
	float beta[2] = { 2, -4 };
	float out[6];
	plShapeBlendJob job = { plMakeConstSpan( t, 2, 12 ), g, plMakeConstSpan( beta, 2, 4 ), plMakeSpan( out, 2, 12 ) };
	assert_int_equal( plShapeBlendJob_Run( &job ), PLEAT_RESULT_OK );
	const float expected[6] = { 1, 4, 5, 0, 2, 2 };
	for ( int i = 0; i < 6; ++i )
	{
		assert_float_equal( out[i], expected[i], 0 );
	}
	double joints[6];
	plShapedJointsJob joints_job = { t, g, 2, plMakeConstSpan( beta, 2, 4 ), joints };
	assert_int_equal( plShapedJointsJob_Run( &joints_job ), PLEAT_RESULT_OK );
	for ( int i = 0; i < 6; ++i )
	{
		assert_float_equal( joints[i], expected[i], 0 );
	}
	// β = 0 components (B = 0) leave the template as it is, with no shapes at all.
	job.beta = plMakeConstSpan( NULL, 0, 4 );
	job.shape_blend_shapes = NULL;
	assert_int_equal( plShapeBlendJob_Run( &job ), PLEAT_RESULT_OK );
	assert_memory_equal( out, t, sizeof( t ) );

	plShapeBlendJob bad[4] = { job, job, job, job };
	bad[0].beta = plMakeConstSpan( beta, 2, 4 );            // shapes missing for B = 2
	bad[1].output = plMakeSpan( out, 1, 12 );                // output shorter than the template
	bad[2].template_positions = plMakeConstSpan( t, 2, 16 ); // not packed
	bad[3].output.ptr = NULL;                                // no output
	for ( int i = 0; i < 4; ++i )
	{
		assert_false( plShapeBlendJob_Validate( &bad[i] ) );
		assert_int_equal( plShapeBlendJob_Run( &bad[i] ), PLEAT_RESULT_INVALID_ARGUMENT );
	}
	joints_job.joint_count = PLEAT_MAX_JOINTS + 1;
	assert_int_equal( plShapedJointsJob_Run( &joints_job ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plShapeBlendJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plShapedJointsJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
}

// Normalisation: ((3 − 1) / 4, (−2 − 0) / 0.5) = (0.5, −4), in place. Latent guard with mean (1, 1), std (2, 2) and
// range [−1, 2]: y = (0.25, 5) → (1.5, 11) → (1.5, 2); y = −3 → −5 → −1.
static void test_input_normalisation_and_latent_guard_by_hand( void** state )
{
	(void)state;
	float x[2] = { 3, -2 }, mean[2] = { 1, 0 }, std[2] = { 4, 0.5f };
	plInputNormalisationJob norm = { plMakeConstSpan( x, 2, 4 ), mean, std, plMakeSpan( x, 2, 4 ) };
	assert_int_equal( plInputNormalisationJob_Run( &norm ), PLEAT_RESULT_OK );
	assert_float_equal( x[0], 0.5f, 0 );
	assert_float_equal( x[1], -4.0f, 0 );

	float y[3] = { 0.25f, 5, -3 }, z[3];
	float z_mean[3] = { 1, 1, 1 }, z_std[3] = { 2, 2, 2 }, z_min[3] = { -1, -1, -1 }, z_max[3] = { 2, 2, 2 };
	plLatentGuardJob guard = { plMakeConstSpan( y, 3, 4 ), z_mean, z_std, z_min, z_max, plMakeSpan( z, 3, 4 ) };
	assert_int_equal( plLatentGuardJob_Run( &guard ), PLEAT_RESULT_OK );
	assert_float_equal( z[0], 1.5f, 0 );
	assert_float_equal( z[1], 2.0f, 0 );
	assert_float_equal( z[2], -1.0f, 0 );

	plInputNormalisationJob bad_norm[3] = { norm, norm, norm };
	bad_norm[0].x_std = NULL;                       // no statistics
	bad_norm[1].output = plMakeSpan( x, 1, 4 );     // output shorter than the input
	bad_norm[2].input = plMakeConstSpan( x, 1, 8 ); // not packed
	for ( int i = 0; i < 3; ++i )
	{
		assert_false( plInputNormalisationJob_Validate( &bad_norm[i] ) );
		assert_int_equal( plInputNormalisationJob_Run( &bad_norm[i] ), PLEAT_RESULT_INVALID_ARGUMENT );
	}
	plLatentGuardJob bad_guard[3] = { guard, guard, guard };
	bad_guard[0].z_max = NULL;                     // no range
	bad_guard[1].output = plMakeSpan( z, 2, 4 );   // output shorter than the input
	bad_guard[2].input = plMakeConstSpan( y, 0, 4 ); // empty
	for ( int i = 0; i < 3; ++i )
	{
		assert_false( plLatentGuardJob_Validate( &bad_guard[i] ) );
		assert_int_equal( plLatentGuardJob_Run( &bad_guard[i] ), PLEAT_RESULT_INVALID_ARGUMENT );
	}
	assert_int_equal( plInputNormalisationJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plLatentGuardJob_Run( NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
}

// The rate decision (docs/inputs.md "Network update rate"), dt range [1/64, 1/16] s, binary-exact values:
// no rate: always run with the step's dt; 16 Hz under 64 fps: run when 4 × 1/64 have gathered, with dt 1/16;
// a first frame always runs; a gathered 1/8 is clamped to 1/16; a step dt below the range is clamped up.
// Body contact: joint 0 is the identity, joint 1 a 90° rotation about +Z then a shift of +1 m in x. Anchors at the
// origin with normal +Y:
//   v0 (joint 0): x = (0, −0.005, 0) is 5 mm behind the plane y = 0 → moved to y = offset = 0.002 → (0, 0.002, 0).
//   v1 (joint 0): x = (0.3, 0.010, 0) is 10 mm in front (> offset) → untouched.
//   v2 (joint 1): the anchor goes to M·(0,0,0,1) = (1, 0, 0) and n = R·(0,1,0) = (−1, 0, 0); x = (1.001, 0.5, 0) has
//       d = (x − a)·n = −0.001 → moved by offset − d = 0.003 along (−1, 0, 0) → (0.998, 0.5, 0).
//   v3: zero normal (no anchor) and deep behind → untouched.
//   v4 (half joint 0, half joint 1): M = (I + M1)/2 = [[0.5, −0.5, 0, 0.5], [0.5, 0.5, 0, 0], [0, 0, 1, 0]];
//       a = (0.5, 0, 0), n = normalize(M·(0,1,0)) = normalize(−0.5, 0.5, 0) = (−√½, √½, 0);
//       x = (0.5, 0, 0) is on the plane (d = 0) → moved by 0.002·n = (0.5 − 0.001414, 0.001414, 0).
static void test_body_contact_by_hand( void** state )
{
	(void)state;
	float positions[5 * 3] = { 0, -0.005f, 0, 0.3f, 0.010f, 0, 1.001f, 0.5f, 0, 0, -1.0f, 0, 0.5f, 0, 0 };
	const float anchors[5 * 3] = { 0 };
	const float normals[5 * 3] = { 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0 };
	const uint16_t indices[5 * 2] = { 0, 1, 0, 1, 1, 0, 0, 1, 0, 1 };
	const float weights[5 * 2] = { 1, 0, 1, 0, 1, 0, 1, 0, 0.5f, 0.5f };
	const float matrices[2 * 12] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, /* joint 1: */ 0, -1, 0, 1, 1, 0, 0, 0, 0, 0, 1, 0 };
	float posed[5 * PLEAT_POSED_POINT_FLOATS];
	plBodyPointsJob pose = { anchors, normals, indices, weights, 2, matrices, 2, posed, 5, 0, 5, NULL, NULL, 0, NULL };
	assert_int_equal( plBodyPointsJob_Run( &pose ), PLEAT_RESULT_OK );
	// One point per vertex (asset 1.1: no candidate table, vertex v's point is v).
	plBodyContactJob job = { plMakeSpan( positions, 5, 12 ), posed, 5, NULL, 1, 0.002f, 0, 5, NULL, NULL };
	assert_int_equal( plBodyContactJob_Run( &job ), PLEAT_RESULT_OK );
	const float expected[5 * 3] = { 0, 0.002f, 0, 0.3f, 0.010f, 0, 0.998f, 0.5f, 0, 0, -1.0f, 0,
									0.5f - 0.00141421356f, 0.00141421356f, 0 };
	for ( int i = 0; i < 15; ++i )
	{
		assert_float_equal( positions[i], expected[i], 1e-6f );
	}
	assert_float_equal( posed[3 * PLEAT_POSED_POINT_FLOATS + 3], 0.0f, 0.0f ); // the zero normal: not anchorable,
	assert_float_equal( posed[3 * PLEAT_POSED_POINT_FLOATS + 7], 0.0f, 0.0f ); // never usable
	assert_float_equal( posed[0 * PLEAT_POSED_POINT_FLOATS + 3], 1.0f, 0.0f ); // (a, anchorable), (n, usable)
	assert_float_equal( posed[0 * PLEAT_POSED_POINT_FLOATS + 7], 1.0f, 0.0f );
	// A vertex range leaves the rest alone; a negative or non-finite offset is refused, and so are a candidate count
	// without a table, more candidates than the limit, fewer points than vertices without a table, a point range past P.
	positions[1] = -0.005f;
	job.vertex_begin = 1;
	assert_int_equal( plBodyContactJob_Run( &job ), PLEAT_RESULT_OK );
	assert_float_equal( positions[1], -0.005f, 0.0f );
	job.offset_m = -0.001f;
	assert_int_equal( plBodyContactJob_Run( &job ), PLEAT_RESULT_INVALID_ARGUMENT );
	job.offset_m = 0.002f;
	job.candidate_count = 2;
	assert_int_equal( plBodyContactJob_Run( &job ), PLEAT_RESULT_INVALID_ARGUMENT );
	job.candidate_count = 1;
	job.point_count = 4;
	assert_int_equal( plBodyContactJob_Run( &job ), PLEAT_RESULT_INVALID_ARGUMENT );
	pose.point_end = 6;
	assert_int_equal( plBodyPointsJob_Run( &pose ), PLEAT_RESULT_INVALID_ARGUMENT );
}

// Candidates (asset 1.2), all on joint 0 (the identity): p0 at the origin, normal +Y; p1 at (0.04, 0, 0), normal +X;
// p2 at (0.02, 0, 0) with a zero normal (never usable); offset 0.002. The blend margin: (1 + 0.1)·m + (1 mm)²; the
// reach (plContactReach): 1 within 3 cm of the nearest usable candidate, 0 beyond 5 cm, linear in m between.
//   v0 = (0.036, −0.001, 0), candidates (p0, p1, empty): m = 0.000017 (p1); p0 at 0.001297 is outside the margin
//       (0.0000197), so the plane is p1's alone → d = −0.004 along +X, moved by 0.006 → (0.042, −0.001, 0), although
//       it is behind p0's plane too.
//   v1 = (0.02, −0.001, 0), candidates (p2, p0, p1): p2 is nearest but unusable; p0 and p1 are exactly as far (0.02 =
//       0.04 − 0.02 in binary), equal weights → a = (0.02, 0, 0), n = (√½, √½, 0), d = −0.001·√½ → moved by
//       (0.002 + 0.001·√½)·n = 0.00191421356 per axis → (0.02191421356, 0.00091421356, 0).
//   v2 = (0, −1, 0), candidates (empty, 7 ≥ P, empty): none → untouched, however deep.
//   v3 = (0, −0.04, 0), candidates (p0): m = 0.0016, reach (0.0025 − 0.0016) / (0.0025 − 0.0009) = 0.5625; d = −0.04
//       → moved by 0.5625 · 0.042 = 0.023625 along +Y → (0, −0.016375, 0).
//   v4 = (0, −0.06, 0), candidates (p0): 6 cm from its only candidate, beyond the reach → untouched.
static void test_body_contact_blends_the_nearest_usable_candidates_by_hand( void** state )
{
	(void)state;
	float positions[5 * 3] = { 0.036f, -0.001f, 0, 0.02f, -0.001f, 0, 0, -1.0f, 0, 0, -0.04f, 0, 0, -0.06f, 0 };
	const float points[3 * 3] = { 0, 0, 0, 0.04f, 0, 0, 0.02f, 0, 0 };
	const float normals[3 * 3] = { 0, 1, 0, 1, 0, 0, 0, 0, 0 };
	const uint16_t indices[3] = { 0, 0, 0 };
	const float weights[3] = { 1, 1, 1 };
	const float matrices[12] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0 };
	const uint16_t E = PLEAT_NO_CONTACT_CANDIDATE;
	const uint16_t candidates[5 * 3] = { 0, 1, E, 2, 0, 1, E, 7, E, 0, E, E, 0, E, E };
	float posed[3 * PLEAT_POSED_POINT_FLOATS];
	plBodyPointsJob pose = { points, normals, indices, weights, 1, matrices, 1, posed, 3, 0, 3, NULL, NULL, 0, NULL };
	assert_int_equal( plBodyPointsJob_Run( &pose ), PLEAT_RESULT_OK );
	plBodyContactJob job = { plMakeSpan( positions, 5, 12 ), posed, 3, candidates, 3, 0.002f, 0, 5, NULL, NULL };
	assert_int_equal( plBodyContactJob_Run( &job ), PLEAT_RESULT_OK );
	const float expected[5 * 3] = { 0.042f, -0.001f, 0, 0.02191421356f, 0.00091421356f, 0, 0, -1.0f, 0,
									0, -0.016375f, 0, 0, -0.06f, 0 };
	for ( int i = 0; i < 15; ++i )
	{
		assert_float_equal( positions[i], expected[i], 1e-6f );
	}
	job.candidate_count = PLEAT_MAX_CONTACT_CANDIDATES + 1;
	assert_int_equal( plBodyContactJob_Run( &job ), PLEAT_RESULT_INVALID_ARGUMENT );
}

// The posed body's normal at a point from its ring (BARG), identity pose: p0 at the origin, rest normal +Y, ring
// (p1, p2, p3, p4) = (1, 0, 0), (0, 1, 0), (−1, 0, 0), (0, −1, 0), counter-clockwise seen from +Z:
// Σ d_i × d_(i+1) = 4 · (0, 0, 1) → +Z, not the rest normal. p1 has no ring → keeps its blended rest normal +Y. p2's
// ring (p1, p3, p1) is flat through it (a zero sum) → not usable. p3 and p4 have zero rest normals (ring corners only):
// posed (p0's normal reads them) and never usable.
static void test_body_point_normals_from_rings_by_hand( void** state )
{
	(void)state;
	const float points[5 * 3] = { 0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0 };
	const float normals[5 * 3] = { 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0 };
	const uint16_t indices[5] = { 0, 0, 0, 0, 0 };
	const float weights[5] = { 1, 1, 1, 1, 1 };
	const float matrices[12] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0 };
	const uint16_t E = PLEAT_NO_CONTACT_CANDIDATE;
	const uint16_t rings[5 * 4] = { 1, 2, 3, 4, /* p1 */ E, E, E, E, /* p2 */ 1, 3, 1, E, /* p3 */ E, E, E, E,
									/* p4 */ 0, 1, 2, E };
	float posed[5 * PLEAT_POSED_POINT_FLOATS];
	plBodyPointsJob pose = { points, normals, indices, weights, 1, matrices, 1, posed, 5, 0, 5, NULL, NULL, 0, NULL };
	assert_int_equal( plBodyPointsJob_Run( &pose ), PLEAT_RESULT_OK );
	assert_float_equal( posed[3 * PLEAT_POSED_POINT_FLOATS + 0], -1.0f, 0.0f ); // a corner is posed too
	plBodyPointNormalsJob job = { posed, 5, rings, 4, 0, 5, NULL, NULL };
	assert_int_equal( plBodyPointNormalsJob_Run( &job ), PLEAT_RESULT_OK );
	const float expected[5][4] = { { 0, 0, 1, 1 }, { 0, 1, 0, 1 }, { 0, 0, 0, 0 }, { 0, 0, 0, 0 }, { 0, 0, 0, 0 } };
	for ( int p = 0; p < 5; ++p )
	{
		const float* row = posed + p * PLEAT_POSED_POINT_FLOATS;
		for ( int e = 0; e < 4; ++e )
		{
			assert_float_equal( row[4 + e], expected[p][e], 1e-7f ); // n, then usable: the row's second half
		}
	}
	job.ring_count = PLEAT_MAX_POINT_RING + 1;
	assert_int_equal( plBodyPointNormalsJob_Run( &job ), PLEAT_RESULT_INVALID_ARGUMENT );
}

static void test_network_rate_decision_by_hand( void** state )
{
	(void)state;
	const float lo = 1.0f / 64.0f, hi = 1.0f / 16.0f;
	plNetworkUpdate u = plDecideNetworkUpdate( 0.0, 0.0, 1.0f / 32.0f, 0, lo, hi );
	assert_true( u.run && u.dt_s == 1.0 / 32.0 && !u.dt_clamped );
	u = plDecideNetworkUpdate( 1.0 / 16.0, 2.0 / 64.0, 1.0f / 64.0f, 0, lo, hi ); // 3/64 < 1/16: held
	assert_true( !u.run && u.dt_s == 1.0 / 64.0 && !u.dt_clamped );
	u = plDecideNetworkUpdate( 1.0 / 16.0, 3.0 / 64.0, 1.0f / 64.0f, 0, lo, hi ); // 4/64 = 1/16: run
	assert_true( u.run && u.dt_s == 1.0 / 16.0 && !u.dt_clamped );
	u = plDecideNetworkUpdate( 1.0 / 16.0, 0.0, 1.0f / 64.0f, 1, lo, hi ); // first frame
	assert_true( u.run && u.dt_s == 1.0 / 64.0 && !u.dt_clamped );
	u = plDecideNetworkUpdate( 1.0 / 8.0, 7.0 / 64.0, 1.0f / 64.0f, 0, lo, hi ); // 8/64 gathered, above 1/16
	assert_true( u.run && u.dt_s == 1.0 / 16.0 && u.dt_clamped );
	u = plDecideNetworkUpdate( 0.0, 0.0, 1.0f / 128.0f, 0, lo, hi ); // below 1/64
	assert_true( u.run && u.dt_s == (double)lo && u.dt_clamped );
	// 25 Hz under 100 fps: 4 × float(0.01) falls a rounding error short of 1/25 and still runs (the 1e-6 slack).
	u = plDecideNetworkUpdate( 1.0 / 25.0, 3.0 * (double)0.01f, 0.01f, 0, lo, hi );
	assert_true( u.run );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_identity_pose_and_zero_weights_give_template ),
		cmocka_unit_test( test_rotating_one_joint_90_degrees_moves_its_vertices ),
		cmocka_unit_test( test_normals_of_flat_quad_and_area_weighting ),
		cmocka_unit_test( test_skinning_writes_interleaved_span ),
		cmocka_unit_test( test_jobs_reject_invalid_spans ),
		cmocka_unit_test( test_mlp_small_network_by_hand ),
		cmocka_unit_test( test_input_assembly_against_hand_values ),
		cmocka_unit_test( test_forward_kinematics_chain ),
		cmocka_unit_test( test_shape_blend_and_shaped_joints_by_hand ),
		cmocka_unit_test( test_input_normalisation_and_latent_guard_by_hand ),
		cmocka_unit_test( test_network_rate_decision_by_hand ),
		cmocka_unit_test( test_body_contact_by_hand ),
		cmocka_unit_test( test_body_contact_blends_the_nearest_usable_candidates_by_hand ),
		cmocka_unit_test( test_body_point_normals_from_rings_by_hand ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
