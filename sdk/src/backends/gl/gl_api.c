#include "gl_api.h"
#include <string.h>

void plGlApi_LoadEpoxy( plGlApi* api )
{
	// epoxy's gl* names are macros for its global dispatch pointers; copying them is enough, the first call through
	// each resolves it against whichever context is current then.
#define PLEAT_GL_LOAD_EPOXY( type, name ) api->name = gl##name;
	PLEAT_GL_FUNCTIONS( PLEAT_GL_LOAD_EPOXY )
#undef PLEAT_GL_LOAD_EPOXY
}

int plGlApi_LoadWith( plGlApi* api, void* ( *get_proc_address )( const char* name ) )
{
	int complete = 1;
	// Converting void* to a function pointer is what every GetProcAddress loader does; POSIX guarantees it works.
#define PLEAT_GL_LOAD_WITH( type, name )                                                                               \
	{                                                                                                                  \
		void* proc = get_proc_address( "gl" #name );                                                                   \
		memcpy( &api->name, &proc, sizeof( proc ) );                                                                  \
		complete = complete && proc != NULL;                                                                           \
	}
	PLEAT_GL_FUNCTIONS( PLEAT_GL_LOAD_WITH )
#undef PLEAT_GL_LOAD_WITH
	return complete;
}
