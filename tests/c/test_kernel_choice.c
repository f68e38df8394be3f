// Which CPU kernels a context runs: the AVX2 set exactly when the build compiled it (CMake's PLEAT_HAVE_AVX2, off in
// a PLEAT_FORCE_SCALAR build) and the CPU has AVX2 + FMA, unless the def asks for scalar; the log says which. The
// forced-scalar CI stage (scripts/ci-stages.sh) relies on this to know its ctest run really exercised the scalar
// kernels everywhere, the whole-pipeline and determinism tests included.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "pleat/pleat.h"

#ifndef PLEAT_TEST_BUILD_HAS_AVX2
#error "tests/c/CMakeLists.txt passes PLEAT_TEST_BUILD_HAS_AVX2 (0 or 1)"
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

typedef struct plKernelLog
{
	int scalar_items;
	int avx2_items;
} plKernelLog;

static void plRecordKernels( plLogLevel level, plLogItem item, const char* message, void* user )
{
	(void)level;
	(void)message;
	plKernelLog* log = (plKernelLog*)user;
	log->scalar_items += item == PLEAT_LOG_KERNELS_SCALAR;
	log->avx2_items += item == PLEAT_LOG_KERNELS_AVX2;
}

// The kernel set a context with this def reports; the deprecated plContext_UsesAvx2 must say the same.
static int plContextUsesAvx2( int force_scalar, plKernelLog* log )
{
	plContextDef def = plDefaultContextDef();
	def.force_scalar = force_scalar;
	def.log = plRecordKernels;
	def.log_context = log;
	plContext context;
	assert_int_equal( plCreateContext( &def, &context ), PLEAT_RESULT_OK );
	plKernelSet kernel_set = (plKernelSet)-1;
	assert_int_equal( plContext_GetKernelSet( context, &kernel_set ), PLEAT_RESULT_OK );
	assert_true( kernel_set == PLEAT_KERNEL_SET_SCALAR || kernel_set == PLEAT_KERNEL_SET_AVX2 );
	int avx2 = -1;
#if defined( __GNUC__ )
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#endif
	assert_int_equal( plContext_UsesAvx2( context, &avx2 ), PLEAT_RESULT_OK );
#if defined( __GNUC__ )
#pragma GCC diagnostic pop
#endif
	assert_int_equal( avx2, kernel_set == PLEAT_KERNEL_SET_AVX2 );
	assert_int_equal( plDestroyContext( context ), PLEAT_RESULT_OK );
	// A destroyed context reports nothing, and a missing out parameter is rejected.
	assert_int_equal( plContext_GetKernelSet( context, &kernel_set ), PLEAT_RESULT_INVALID_HANDLE );
	assert_int_equal( kernel_set, PLEAT_KERNEL_SET_SCALAR );
	assert_int_equal( plContext_GetKernelSet( context, NULL ), PLEAT_RESULT_INVALID_ARGUMENT );
	return avx2;
}

static void test_default_context_uses_avx2_exactly_when_built_and_supported( void** state )
{
	(void)state;
	plKernelLog log = { 0, 0 };
	int expected = PLEAT_TEST_BUILD_HAS_AVX2 && plCpuHasAvx2Fma();
	assert_int_equal( plContextUsesAvx2( 0, &log ), expected );
	assert_int_equal( log.avx2_items, expected );
	assert_int_equal( log.scalar_items, !expected );
	print_message( "build %s the AVX2 kernels; this CPU %s AVX2 + FMA; default context: %s\n",
				   PLEAT_TEST_BUILD_HAS_AVX2 ? "has" : "lacks", plCpuHasAvx2Fma() ? "has" : "lacks",
				   expected ? "AVX2" : "scalar" );
}

static void test_force_scalar_def_uses_scalar_kernels( void** state )
{
	(void)state;
	plKernelLog log = { 0, 0 };
	assert_false( plContextUsesAvx2( 1, &log ) );
	assert_int_equal( log.scalar_items, 1 );
	assert_int_equal( log.avx2_items, 0 );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_default_context_uses_avx2_exactly_when_built_and_supported ),
		cmocka_unit_test( test_force_scalar_def_uses_scalar_kernels ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
