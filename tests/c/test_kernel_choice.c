// Which CPU kernels a context runs: the widest set up to the def's max_isa that the build compiled (CMake's
// PLEAT_HAVE_AVX2 and PLEAT_HAVE_AVX512, both off in a PLEAT_FORCE_SCALAR build) and the CPU runs — AVX2 where it has
// AVX2 + FMA, AVX-512 where it also has AVX-512 F/VL/BW/DQ — decided once at creation, reported by
// plContext_GetKernelSet and by one log item. The deprecated force_scalar still means scalar. The forced-scalar CI
// stage (scripts/ci-stages.sh) relies on this to know its ctest run really exercised the scalar kernels everywhere,
// the whole-pipeline and determinism tests included.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "pleat/pleat.h"

#ifndef PLEAT_TEST_BUILD_HAS_AVX2
#error "tests/c/CMakeLists.txt passes PLEAT_TEST_BUILD_HAS_AVX2 (0 or 1)"
#endif
#ifndef PLEAT_TEST_BUILD_HAS_AVX512
#error "tests/c/CMakeLists.txt passes PLEAT_TEST_BUILD_HAS_AVX512 (0 or 1)"
#endif

static int plCpuHasAvx2Fma( void )
{
#if ( defined( __x86_64__ ) || defined( __i386__ ) ) && ( defined( __GNUC__ ) || defined( __clang__ ) )
	__builtin_cpu_init();
	return __builtin_cpu_supports( "avx2" ) && __builtin_cpu_supports( "fma" );
#else
	return 0;
#endif
}

static int plCpuHasAvx512( void )
{
#if ( defined( __x86_64__ ) || defined( __i386__ ) ) && ( defined( __GNUC__ ) || defined( __clang__ ) )
	__builtin_cpu_init();
	return plCpuHasAvx2Fma() && __builtin_cpu_supports( "avx512f" ) && __builtin_cpu_supports( "avx512vl" ) &&
		   __builtin_cpu_supports( "avx512bw" ) && __builtin_cpu_supports( "avx512dq" );
#else
	return 0;
#endif
}

// The widest set this build and CPU run, worked out here independently of the library.
static plKernelSet plWidestSet( void )
{
	if ( !PLEAT_TEST_BUILD_HAS_AVX2 || !plCpuHasAvx2Fma() )
	{
		return PLEAT_KERNEL_SET_SCALAR;
	}
	return PLEAT_TEST_BUILD_HAS_AVX512 && plCpuHasAvx512() ? PLEAT_KERNEL_SET_AVX512 : PLEAT_KERNEL_SET_AVX2;
}

typedef struct plKernelLog
{
	int items[3]; // KERNELS_SCALAR, KERNELS_AVX2, KERNELS_AVX512 seen
} plKernelLog;

static void plRecordKernels( plLogLevel level, plLogItem item, const char* message, void* user )
{
	(void)level;
	(void)message;
	plKernelLog* log = (plKernelLog*)user;
	log->items[0] += item == PLEAT_LOG_KERNELS_SCALAR;
	log->items[1] += item == PLEAT_LOG_KERNELS_AVX2;
	log->items[2] += item == PLEAT_LOG_KERNELS_AVX512;
}

// The kernel set a context with this def reports, after checking that its one log item and the deprecated
// plContext_UsesAvx2 say the same.
static plKernelSet plContextKernelSet( const plContextDef* base )
{
	plKernelLog log = { { 0, 0, 0 } };
	plContextDef def = *base;
	def.log = plRecordKernels;
	def.log_context = &log;
	plContext context;
	assert_int_equal( plCreateContext( &def, &context ), PLEAT_RESULT_OK );
	plKernelSet kernel_set = (plKernelSet)-1;
	assert_int_equal( plContext_GetKernelSet( context, &kernel_set ), PLEAT_RESULT_OK );
	assert_true( kernel_set >= PLEAT_KERNEL_SET_SCALAR && kernel_set <= PLEAT_KERNEL_SET_AVX512 );
	for ( int set = 0; set < 3; ++set )
	{
		assert_int_equal( log.items[set], set == (int)kernel_set );
	}
	int avx2 = -1;
#if defined( __GNUC__ )
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#endif
	assert_int_equal( plContext_UsesAvx2( context, &avx2 ), PLEAT_RESULT_OK );
#if defined( __GNUC__ )
#pragma GCC diagnostic pop
#endif
	assert_int_equal( avx2, kernel_set != PLEAT_KERNEL_SET_SCALAR ); // the single-instance kernels are AVX2's in both
	assert_int_equal( plDestroyContext( context ), PLEAT_RESULT_OK );
	// A destroyed context reports nothing, and a missing out parameter is rejected.
	plKernelSet after = (plKernelSet)-1;
	assert_int_equal( plContext_GetKernelSet( context, &after ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( after, PLEAT_KERNEL_SET_SCALAR );
	assert_int_equal( plContext_GetKernelSet( context, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	return kernel_set;
}

static const char* plSetName( plKernelSet set )
{
	return set == PLEAT_KERNEL_SET_AVX512 ? "AVX-512" : ( set == PLEAT_KERNEL_SET_AVX2 ? "AVX2" : "scalar" );
}

static void test_default_context_uses_the_widest_set_built_and_supported( void** state )
{
	(void)state;
	plContextDef def = plDefaultContextDef();
	assert_int_equal( def.max_isa, PLEAT_KERNEL_SET_AVX512 );
	assert_int_equal( plContextKernelSet( &def ), plWidestSet() );
	print_message( "build %s the AVX2 kernels and %s the AVX-512 ones; this CPU %s AVX2 + FMA and %s AVX-512; default "
				   "context: %s\n",
				   PLEAT_TEST_BUILD_HAS_AVX2 ? "has" : "lacks", PLEAT_TEST_BUILD_HAS_AVX512 ? "has" : "lacks",
				   plCpuHasAvx2Fma() ? "has" : "lacks", plCpuHasAvx512() ? "has" : "lacks",
				   plSetName( plWidestSet() ) );
}

static void test_max_isa_caps_the_set( void** state )
{
	(void)state;
	for ( int max = PLEAT_KERNEL_SET_SCALAR; max <= PLEAT_KERNEL_SET_AVX512; ++max )
	{
		plContextDef def = plDefaultContextDef();
		def.max_isa = (plKernelSet)max;
		plKernelSet expected = plWidestSet() < (plKernelSet)max ? plWidestSet() : (plKernelSet)max;
		assert_int_equal( plContextKernelSet( &def ), expected );
	}
	// A set above the widest this library knows (a newer header's) asks for the widest.
	plContextDef def = plDefaultContextDef();
	def.max_isa = (plKernelSet)( PLEAT_KERNEL_SET_AVX512 + 5 );
	assert_int_equal( plContextKernelSet( &def ), plWidestSet() );
	// A negative one is no set at all.
	def.max_isa = (plKernelSet)-1;
	plContext context;
	assert_int_equal( plCreateContext( &def, &context ), PLEAT_RESULT_INVALID_DEF );
	assert_false( plContext_IsValid( context ) );
}

static void test_force_scalar_def_uses_scalar_kernels( void** state )
{
	(void)state;
	plContextDef def = plDefaultContextDef();
	def.force_scalar = 1; // deprecated, still honoured: it wins over max_isa
	assert_int_equal( plContextKernelSet( &def ), PLEAT_KERNEL_SET_SCALAR );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_default_context_uses_the_widest_set_built_and_supported ),
		cmocka_unit_test( test_max_isa_caps_the_set ),
		cmocka_unit_test( test_force_scalar_def_uses_scalar_kernels ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
