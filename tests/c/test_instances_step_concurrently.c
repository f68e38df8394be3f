// Threading rule of pleat.h: after creation, different instances may be stepped at the same time from different
// threads. Two threads step two instances of one shared asset at once, each with its own motion, β and output span,
// and must get bit for bit what the same instances give when stepped one after the other; then the same with two
// contexts whose task systems run real worker threads (plTestTaskSystem), so the SDK's range splitting runs
// concurrently too. Built normally it checks the results; under PLEAT_TSAN (scripts/ci-stages.sh) ThreadSanitizer
// also checks that the two steps share no unsynchronised state (asset, context, kernels, ONNX-free paths).
#define _POSIX_C_SOURCE 200809L
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "test_common.h"
#include "test_task_system.h"

#define PLEAT_THREAD_FRAMES 40

typedef struct plStepper
{
	plInstance instance;
	uint32_t joint_count;
	uint32_t vertex_count;
	uint32_t phase;             // offsets the motion so the two instances differ
	float* positions;           // output span [N][4] (stride 16)
	uint64_t hash;              // positions and normals of every frame
	int failures;               // steps that returned an error
	pthread_barrier_t* barrier; // lines the threads up so their steps overlap
} plStepper;

static void* plStepperRun( void* arg )
{
	plStepper* s = (plStepper*)arg;
	float q[64 * 4];
	for ( uint32_t t = 0; t < PLEAT_THREAD_FRAMES; ++t )
	{
		if ( s->barrier != NULL )
		{
			pthread_barrier_wait( s->barrier );
		}
		plFrameInput in = plTestMotion( t + s->phase, s->joint_count, q );
		plStepOutput out;
		memset( &out, 0, sizeof( out ) );
		out.positions = s->positions;
		out.position_stride_bytes = 16;
		out.vertex_capacity = s->vertex_count;
		if ( plInstance_Step( s->instance, &in, &out ) < 0 )
		{
			s->failures++;
			continue;
		}
		const float* normals = NULL;
		plInstance_GetNormals( s->instance, &normals, NULL );
		s->hash = plTestHash( s->positions, (size_t)s->vertex_count * 16, s->hash );
		s->hash = plTestHash( normals, (size_t)s->vertex_count * 3 * sizeof( float ), s->hash );
	}
	return NULL;
}

static plTestAsset* plMakeModel( void )
{
	plTestAssetParams p = plTestAsset_DefaultParams();
	p.grid_x = 30;
	p.grid_y = 20; // N = 600: several normal and skinning ranges
	p.lp_hidden[0] = 96;
	p.dec_hidden[0] = 64;
	p.latent_count = 16;
	p.blend_count = 12;
	return plTestAsset_Create( &p );
}

static void plStepper_Init( plStepper* s, plInstance instance, const plTestAsset* model, uint32_t phase )
{
	memset( s, 0, sizeof( *s ) );
	s->instance = instance;
	s->joint_count = model->J;
	s->vertex_count = model->N;
	s->phase = phase;
	s->positions = (float*)calloc( (size_t)model->N * 4, sizeof( float ) );
	assert_non_null( s->positions );
}

static plInstance plShapedInstance( plContext context, plAsset asset, float beta0 )
{
	float beta[2] = { beta0, -0.5f * beta0 };
	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = asset;
	idef.beta = beta;
	idef.beta_count = 2;
	plInstance instance;
	assert_int_equal( plCreateInstance( context, &idef, &instance ), PLEAT_RESULT_OK );
	return instance;
}

// Steps a and b: one after the other (parallel = 0) or from two threads at once (parallel = 1).
static void plStepBoth( plStepper* a, plStepper* b, int parallel )
{
	if ( !parallel )
	{
		plStepperRun( a );
		plStepperRun( b );
		return;
	}
	pthread_barrier_t barrier;
	assert_int_equal( pthread_barrier_init( &barrier, NULL, 2 ), 0 );
	a->barrier = &barrier;
	b->barrier = &barrier;
	pthread_t thread;
	assert_int_equal( pthread_create( &thread, NULL, plStepperRun, b ), 0 );
	plStepperRun( a );
	assert_int_equal( pthread_join( thread, NULL ), 0 );
	pthread_barrier_destroy( &barrier );
	a->barrier = b->barrier = NULL;
}

// One context, one shared asset, two instances with different β and motion.
static void plRunSharedAsset( int parallel, uint64_t* hash_a, uint64_t* hash_b )
{
	plTestAsset* model = plMakeModel();
	plTestRig rig;
	assert_int_equal( plTestRig_Init( &rig, model, NULL ), PLEAT_RESULT_OK );
	plStepper a, b;
	plStepper_Init( &a, plShapedInstance( rig.context, rig.asset, 0.8f ), model, 0 );
	plStepper_Init( &b, plShapedInstance( rig.context, rig.asset, -1.3f ), model, 17 );
	plStepBoth( &a, &b, parallel );
	assert_int_equal( a.failures + b.failures, 0 );
	*hash_a = a.hash;
	*hash_b = b.hash;
	free( a.positions );
	free( b.positions );
	plTestRig_Free( &rig );
	plTestAsset_Destroy( model );
}

static void test_two_threads_step_two_instances_of_one_asset( void** state )
{
	(void)state;
	uint64_t serial_a, serial_b, parallel_a, parallel_b;
	plRunSharedAsset( 0, &serial_a, &serial_b );
	assert_true( serial_a != serial_b ); // the two instances really do different work
	for ( int repeat = 0; repeat < 3; ++repeat )
	{
		plRunSharedAsset( 1, &parallel_a, &parallel_b );
		assert_true( parallel_a == serial_a );
		assert_true( parallel_b == serial_b );
	}
}

// Two contexts, each with a two-worker task system of real threads: four threads in the SDK at once.
static void plRunTwoContexts( int parallel, uint64_t* hash_a, uint64_t* hash_b, uint32_t* parallel_tasks )
{
	plTestAsset* model = plMakeModel();
	plTestTaskSystem* tasks_a = plTestTaskSystem_Create( 2 );
	plTestTaskSystem* tasks_b = plTestTaskSystem_Create( 2 );
	plContextDef def_a = plDefaultContextDef(), def_b = plDefaultContextDef();
	plTestTaskSystem_Install( tasks_a, &def_a );
	plTestTaskSystem_Install( tasks_b, &def_b );
	def_b.force_scalar = 1; // one context on each kernel set
	plTestRig rig_a, rig_b;
	assert_int_equal( plTestRig_Init( &rig_a, model, &def_a ), PLEAT_RESULT_OK );
	assert_int_equal( plTestRig_Init( &rig_b, model, &def_b ), PLEAT_RESULT_OK );
	plStepper a, b;
	plStepper_Init( &a, plShapedInstance( rig_a.context, rig_a.asset, 0.3f ), model, 5 );
	plStepper_Init( &b, plShapedInstance( rig_b.context, rig_b.asset, 1.1f ), model, 9 );
	plStepBoth( &a, &b, parallel );
	assert_int_equal( a.failures + b.failures, 0 );
	*hash_a = a.hash;
	*hash_b = b.hash;
	*parallel_tasks = plTestTaskSystem_ParallelTaskCount( tasks_a ) + plTestTaskSystem_ParallelTaskCount( tasks_b );
	free( a.positions );
	free( b.positions );
	plTestRig_Free( &rig_a );
	plTestRig_Free( &rig_b );
	plTestTaskSystem_Destroy( tasks_a );
	plTestTaskSystem_Destroy( tasks_b );
	plTestAsset_Destroy( model );
}

static void test_two_threads_step_two_contexts_with_worker_threads( void** state )
{
	(void)state;
	uint64_t serial_a, serial_b, parallel_a, parallel_b;
	uint32_t tasks = 0;
	plRunTwoContexts( 0, &serial_a, &serial_b, &tasks );
	assert_true( tasks > 0 ); // the work was split over worker threads
	plRunTwoContexts( 1, &parallel_a, &parallel_b, &tasks );
	assert_true( parallel_a == serial_a );
	assert_true( parallel_b == serial_b );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_two_threads_step_two_instances_of_one_asset ),
		cmocka_unit_test( test_two_threads_step_two_contexts_with_worker_threads ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
