// A headless GL instance says in the log which platform, device and renderer it got (PLEAT_LOG_GL_HEADLESS_CONTEXT),
// and the choice follows the documented order: an EGL device that is hardware when this machine has one (checked here
// independently, by enumerating the EGL devices), otherwise Mesa's surfaceless platform (llvmpipe here), then OSMesa.
// When no route works, the GL_UNAVAILABLE error says why each one failed.
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "pleat/pleat.h"
#include "test_asset_builder.h"
#include <epoxy/egl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct plLogLines
{
	int count;
	plLogLevel levels[32];
	plLogItem items[32];
	char messages[32][512];
} plLogLines;

static void plKeepLog( plLogLevel level, plLogItem item, const char* message, void* user )
{
	plLogLines* lines = (plLogLines*)user;
	if ( lines->count >= 32 )
		return;
	lines->levels[lines->count] = level;
	lines->items[lines->count] = item;
	snprintf( lines->messages[lines->count], sizeof( lines->messages[0] ), "%s", message );
	lines->count++;
}

static const char* plFindItem( const plLogLines* lines, plLogItem item, plLogLevel level )
{
	for ( int i = 0; i < lines->count; ++i )
	{
		if ( lines->items[i] == item && lines->levels[i] == level )
			return lines->messages[i];
	}
	return NULL;
}

// EGL devices without Mesa's software mark, counted the test's own way (0 when the device platform is absent).
static int plHardwareEglDevices( int* out_software )
{
	*out_software = 0;
	const char* client = eglQueryString( EGL_NO_DISPLAY, EGL_EXTENSIONS );
	if ( !epoxy_extension_in_string( client, "EGL_EXT_platform_device" ) ||
		 !( epoxy_extension_in_string( client, "EGL_EXT_device_base" ) ||
			epoxy_extension_in_string( client, "EGL_EXT_device_enumeration" ) ) )
		return 0;
	EGLDeviceEXT devices[16];
	EGLint count = 0;
	if ( !eglQueryDevicesEXT( 16, devices, &count ) )
		return 0;
	int hardware = 0;
	for ( EGLint i = 0; i < count; ++i )
	{
		const char* extensions = eglQueryDeviceStringEXT( devices[i], EGL_EXTENSIONS );
		if ( epoxy_extension_in_string( extensions, "EGL_MESA_device_software" ) )
			*out_software += 1;
		else
			hardware += 1;
	}
	return hardware;
}

static void test_headless_instance_logs_platform_device_and_renderer( void** state )
{
	(void)state;
	plTestAssetParams params = plTestAsset_DefaultParams();
	plTestAsset* model = plTestAsset_Create( &params );
	assert_non_null( model );
	size_t size = 0;
	uint8_t* bytes = plTestAsset_Write( model, &size );
	plTestAsset_Destroy( model );
	assert_non_null( bytes );
	static plLogLines lines;
	memset( &lines, 0, sizeof( lines ) );
	plContextDef cdef = plDefaultContextDef();
	cdef.log = plKeepLog;
	cdef.log_context = &lines;
	plContext context;
	assert_int_equal( plCreateContext( &cdef, &context ), PLEAT_RESULT_OK );
	plAssetDef adef = plDefaultAssetDef();
	adef.data = bytes;
	adef.size = size;
	plAsset asset;
	assert_int_equal( plLoadAsset( context, &adef, &asset ), PLEAT_RESULT_OK );

	plInstanceDef idef = plDefaultInstanceDef();
	idef.asset = asset;
	idef.gpu_mode = PLEAT_GPU_MODE_HEADLESS;
	plInstance instance;
	plResult result = plCreateInstance( context, &idef, &instance );
	if ( result == PLEAT_RESULT_GL_UNAVAILABLE )
	{
		// No route worked: the error names each one's failure.
		const char* error = plFindItem( &lines, PLEAT_LOG_GL_UNAVAILABLE, PLEAT_LOG_LEVEL_ERROR );
		assert_non_null( error );
		print_message( "SKIP (no headless GL here): %s\n", error );
		assert_non_null( strstr( error, "EGL" ) );
		assert_non_null( strstr( error, "OSMesa" ) );
		plDestroyContext( context );
		plTestAsset_FreeBytes( bytes );
		skip();
	}
	assert_int_equal( result, PLEAT_RESULT_OK );
	const char* report = plFindItem( &lines, PLEAT_LOG_GL_HEADLESS_CONTEXT, PLEAT_LOG_LEVEL_INFO );
	assert_non_null( report );
	print_message( "logged: %s\n", report );
	assert_non_null( strstr( report, plLogItemString( PLEAT_LOG_GL_HEADLESS_CONTEXT ) ) );
	assert_non_null( strstr( report, "GL_RENDERER '" ) );
	assert_non_null( strstr( report, "GL_VENDOR '" ) );
	assert_non_null( strstr( report, "GL_VERSION '" ) );
	const char* chosen = strstr( report, ": " ) + 2; // after the item's fixed text

	int software = 0, hardware = plHardwareEglDevices( &software );
	if ( hardware > 0 )
	{
		// A hardware device is chosen, or the report says why each hardware device could not be used.
		int chose_hardware = strncmp( chosen, "EGL device platform (EGL_EXT_platform_device)", 45 ) == 0 &&
							 strstr( chosen, ", hardware;" ) != NULL;
		assert_true( chose_hardware || strstr( chosen, "hardware: " ) != NULL );
	}
	else
	{
		assert_true( strncmp( chosen, "EGL surfaceless platform (EGL_MESA_platform_surfaceless)", 56 ) == 0 ||
					 strncmp( chosen, "OSMesa", 6 ) == 0 );
		if ( software > 0 )
			assert_non_null( strstr( chosen, "software, passed over" ) ); // the software device was seen, not taken
	}
	assert_int_equal( plDestroyInstance( instance ), PLEAT_RESULT_OK );
	plDestroyContext( context );
	plTestAsset_FreeBytes( bytes );
}

int main( void )
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test( test_headless_instance_logs_platform_device_and_renderer ),
	};
	return cmocka_run_group_tests( tests, NULL, NULL );
}
