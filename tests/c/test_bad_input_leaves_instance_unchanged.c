// Every kind of bad input returns its documented code, and the instance's next output is bit-identical to a twin
// instance that never saw the bad call (same asset, same good frames). Out-of-range β / material / dt are clamped
// (PLEAT_RESULT_CLAMPED) and then behave exactly like the clamped value given directly.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "test_common.h"

typedef struct plTwinFixture
{
	plTestAsset* model;
	plTestRig rig;
	plInstance subject, twin;
	uint32_t frame;
	float quats[64 * 4];
} plTwinFixture;

static int plTwinSetup( void** state )
{
	plTwinFixture* f = (plTwinFixture*)calloc( 1, sizeof( plTwinFixture ) );
	plTestAssetParams p = plTestAsset_DefaultParams();
	f->model = plTestAsset_Create( &p );
	if ( plTestRig_Init( &f->rig, f->model, NULL ) != PLEAT_RESULT_OK ||
		 plTestRig_Instance( &f->rig, &f->subject ) != PLEAT_RESULT_OK ||
		 plTestRig_Instance( &f->rig, &f->twin ) != PLEAT_RESULT_OK )
	{
		return -1;
	}
	*state = f;
	return 0;
}

static int plTwinTeardown( void** state )
{
	plTwinFixture* f = (plTwinFixture*)*state;
	plTestRig_Free( &f->rig );
	plTestAsset_Destroy( f->model );
	free( f );
	return 0;
}

// Steps both instances with the next good frame and asserts identical positions, normals, latent, skin matrices.
static void plStepBothAndCompare( plTwinFixture* f )
{
	plFrameInput in = plTestMotion( f->frame++, f->model->J, f->quats );
	plResult a = plInstance_Step( f->subject, &in, NULL );
	plResult b = plInstance_Step( f->twin, &in, NULL );
	assert_int_equal( a, b );
	assert_true( a >= 0 );
	const float *pa, *pb, *na, *nb;
	plInstance_GetPositions( f->subject, &pa, NULL );
	plInstance_GetPositions( f->twin, &pb, NULL );
	plInstance_GetNormals( f->subject, &na, NULL );
	plInstance_GetNormals( f->twin, &nb, NULL );
	assert_memory_equal( pa, pb, f->model->N * 3 * sizeof( float ) );
	assert_memory_equal( na, nb, f->model->N * 3 * sizeof( float ) );
	float la[64], lb[64], ma[64 * 12], mb[64 * 12];
	plInstance_GetLatent( f->subject, la, 64 );
	plInstance_GetLatent( f->twin, lb, 64 );
	assert_memory_equal( la, lb, f->model->L * sizeof( float ) );
	plInstance_GetSkinMatrices( f->subject, ma, 64 );
	plInstance_GetSkinMatrices( f->twin, mb, 64 );
	assert_memory_equal( ma, mb, f->model->J * 12 * sizeof( float ) );
}

// A good frame to corrupt: a copy of the next motion frame (does not advance the motion).
static plFrameInput plNextFrame( plTwinFixture* f, float* quats )
{
	return plTestMotion( f->frame, f->model->J, quats );
}

static void plExpectRejected( plTwinFixture* f, const plFrameInput* in, const plStepOutput* out, plResult expected )
{
	plStepBothAndCompare( f ); // history is non-trivial before the bad call
	assert_int_equal( plInstance_Step( f->subject, in, out ), expected );
	plStepBothAndCompare( f );
	plStepBothAndCompare( f );
}

static void test_null_pointers_are_rejected( void** state )
{
	plTwinFixture* f = (plTwinFixture*)*state;
	float q[64 * 4];
	plExpectRejected( f, NULL, NULL, PLEAT_RESULT_INVALID_ARGUMENT );
	plFrameInput in = plNextFrame( f, q );
	in.joint_rotations = NULL;
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_INVALID_ARGUMENT );
	in = plNextFrame( f, q );
	plInstance null_instance = { 0, 0, { 0, 0 } };
	assert_int_equal( plInstance_Step( null_instance, &in, NULL ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( plInstance_SetMaterial( f->subject, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plInstance_SetShape( f->subject, NULL, 1 ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plInstance_GetPositions( f->subject, NULL, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	assert_int_equal( plInstance_GetLatent( f->subject, NULL, 64 ), PLEAT_RESULT_INVALID_ARGUMENT );
	plStepBothAndCompare( f );
}

static void test_nan_and_inf_in_pose_root_or_dt_are_rejected( void** state )
{
	plTwinFixture* f = (plTwinFixture*)*state;
	float q[64 * 4];
	plFrameInput in = plNextFrame( f, q );
	q[2 * 4 + 1] = NAN;
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_NON_FINITE_INPUT );
	in = plNextFrame( f, q );
	q[0] = INFINITY;
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_NON_FINITE_INPUT );
	in = plNextFrame( f, q );
	in.root_translation.y = INFINITY;
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_NON_FINITE_INPUT );
	in = plNextFrame( f, q );
	in.root_rotation.w = NAN;
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_NON_FINITE_INPUT );
	in = plNextFrame( f, q );
	in.dt_s = NAN;
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_NON_FINITE_INPUT );
	in = plNextFrame( f, q );
	in.dt_s = -INFINITY;
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_NON_FINITE_INPUT );
}

static void test_dt_not_positive_or_over_one_second_is_rejected( void** state )
{
	plTwinFixture* f = (plTwinFixture*)*state;
	float q[64 * 4];
	const float bad[4] = { 0.0f, -0.01f, 1.0001f, 1e9f };
	for ( int i = 0; i < 4; ++i )
	{
		plFrameInput in = plNextFrame( f, q );
		in.dt_s = bad[i];
		plExpectRejected( f, &in, NULL, PLEAT_RESULT_INVALID_DT );
	}
}

static void test_wrong_joint_count_is_rejected( void** state )
{
	plTwinFixture* f = (plTwinFixture*)*state;
	float q[64 * 4];
	plFrameInput in = plNextFrame( f, q );
	in.joint_count = f->model->J - 1;
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_JOINT_COUNT_MISMATCH );
	in.joint_count = f->model->J + 1;
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_JOINT_COUNT_MISMATCH );
	// A joint map with the wrong length or an out-of-range engine index is refused at creation.
	int32_t map[64] = { 0 };
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = f->rig.asset;
	idef.joint_map = map;
	idef.joint_map_count = f->model->J - 1;
	plInstance inst;
	assert_int_equal( plCreateInstance( f->rig.context, &idef, &inst ), PLEAT_RESULT_JOINT_COUNT_MISMATCH );
	assert_false( plInstance_IsValid( inst ) );
	idef.joint_map_count = f->model->J;
	idef.engine_joint_count = 3;
	map[1] = 3;
	assert_int_equal( plCreateInstance( f->rig.context, &idef, &inst ), PLEAT_RESULT_JOINT_COUNT_MISMATCH );
	idef.joint_map = NULL;
	assert_int_equal( plCreateInstance( f->rig.context, &idef, &inst ), PLEAT_RESULT_JOINT_COUNT_MISMATCH );
}

static void test_non_unit_quaternions_are_rejected( void** state )
{
	plTwinFixture* f = (plTwinFixture*)*state;
	float q[64 * 4];
	plFrameInput in = plNextFrame( f, q );
	for ( int c = 0; c < 4; ++c )
	{
		q[1 * 4 + c] *= 1.01f; // length 1.01: outside 1 ± 1e-3
	}
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_INVALID_QUATERNION );
	in = plNextFrame( f, q );
	q[3 * 4 + 0] = q[3 * 4 + 1] = q[3 * 4 + 2] = q[3 * 4 + 3] = 0.0f; // a zero joint quaternion is not identity
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_INVALID_QUATERNION );
	in = plNextFrame( f, q );
	in.root_rotation = ( plQuat ){ 0.0f, 0.5f, 0.0f, 0.5f };
	plExpectRejected( f, &in, NULL, PLEAT_RESULT_INVALID_QUATERNION );
}

static void test_bad_output_spans_are_rejected( void** state )
{
	plTwinFixture* f = (plTwinFixture*)*state;
	float q[64 * 4];
	float* buffer = (float*)calloc( (size_t)f->model->N * 8, sizeof( float ) );
	plFrameInput in = plNextFrame( f, q );
	plStepOutput out;
	memset( &out, 0, sizeof( out ) );
	out.positions = buffer;
	out.vertex_capacity = f->model->N - 1;
	plExpectRejected( f, &in, &out, PLEAT_RESULT_BUFFER_TOO_SMALL );
	out.vertex_capacity = f->model->N;
	out.position_stride_bytes = 8;
	plExpectRejected( f, &in, &out, PLEAT_RESULT_INVALID_ARGUMENT );
	out.position_stride_bytes = 14;
	plExpectRejected( f, &in, &out, PLEAT_RESULT_INVALID_ARGUMENT );
	in.joint_stride_bytes = 12;
	out.position_stride_bytes = 0;
	plExpectRejected( f, &in, &out, PLEAT_RESULT_INVALID_ARGUMENT );
	// The good case writes interleaved positions and normals (stride 32 bytes) equal to the instance's buffers.
	in = plNextFrame( f, q );
	out.position_stride_bytes = 32;
	out.normals = buffer + 4;
	out.normal_stride_bytes = 32;
	f->frame++;
	assert_true( plInstance_Step( f->subject, &in, &out ) >= 0 );
	assert_true( plInstance_Step( f->twin, &in, NULL ) >= 0 );
	const float *p, *n;
	plInstance_GetPositions( f->twin, &p, NULL );
	plInstance_GetNormals( f->twin, &n, NULL );
	for ( uint32_t v = 0; v < f->model->N; ++v )
	{
		assert_memory_equal( buffer + v * 8, p + v * 3, 12 );
		assert_memory_equal( buffer + v * 8 + 4, n + v * 3, 12 );
	}
	free( buffer );
	plStepBothAndCompare( f );
}

static void test_out_of_range_beta_and_material_are_clamped( void** state )
{
	plTwinFixture* f = (plTwinFixture*)*state;
	plStepBothAndCompare( f );
	float wild_beta[2] = { 10.0f, -7.5f }, clamped_beta[2] = { 4.0f, -4.0f };
	assert_int_equal( plInstance_SetShape( f->subject, wild_beta, 2 ), PLEAT_RESULT_CLAMPED );
	assert_int_equal( plInstance_SetShape( f->twin, clamped_beta, 2 ), PLEAT_RESULT_OK );
	float beta[2], material[4];
	assert_int_equal( plInstance_GetShape( f->subject, beta, 2, material ), PLEAT_RESULT_OK );
	assert_float_equal( beta[0], 4.0f, 0 );
	assert_float_equal( beta[1], -4.0f, 0 );
	plStepBothAndCompare( f );
	float wild_material[4] = { 100.0f, 0.0f, 5e4f, -1.0f };
	float clamped_material[4] = { f->model->material_max[0], f->model->material_min[1], 5e4f,
								  f->model->material_min[3] };
	assert_int_equal( plInstance_SetMaterial( f->subject, wild_material ), PLEAT_RESULT_CLAMPED );
	assert_int_equal( plInstance_SetMaterial( f->twin, clamped_material ), PLEAT_RESULT_OK );
	assert_int_equal( plInstance_GetShape( f->subject, NULL, 0, material ), PLEAT_RESULT_OK );
	assert_memory_equal( material, clamped_material, sizeof( material ) );
	plStepBothAndCompare( f );
	// Non-finite β or material, or too many βs: an error, nothing changes.
	float nan_beta[1] = { NAN };
	assert_int_equal( plInstance_SetShape( f->subject, nan_beta, 1 ), PLEAT_RESULT_NON_FINITE_INPUT );
	float three[3] = { 0, 0, 0 };
	assert_int_equal( plInstance_SetShape( f->subject, three, 3 ), PLEAT_RESULT_INVALID_ARGUMENT );
	float inf_material[4] = { 0.1f, INFINITY, 5e4f, 1e-4f };
	assert_int_equal( plInstance_SetMaterial( f->subject, inf_material ), PLEAT_RESULT_NON_FINITE_INPUT );
	plStepBothAndCompare( f );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup_teardown( test_null_pointers_are_rejected, plTwinSetup, plTwinTeardown ),
		cmocka_unit_test_setup_teardown( test_nan_and_inf_in_pose_root_or_dt_are_rejected, plTwinSetup,
										 plTwinTeardown ),
		cmocka_unit_test_setup_teardown( test_dt_not_positive_or_over_one_second_is_rejected, plTwinSetup,
										 plTwinTeardown ),
		cmocka_unit_test_setup_teardown( test_wrong_joint_count_is_rejected, plTwinSetup, plTwinTeardown ),
		cmocka_unit_test_setup_teardown( test_non_unit_quaternions_are_rejected, plTwinSetup, plTwinTeardown ),
		cmocka_unit_test_setup_teardown( test_bad_output_spans_are_rejected, plTwinSetup, plTwinTeardown ),
		cmocka_unit_test_setup_teardown( test_out_of_range_beta_and_material_are_clamped, plTwinSetup,
										 plTwinTeardown ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
