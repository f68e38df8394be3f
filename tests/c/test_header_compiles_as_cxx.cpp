// pleat.h compiles as C++ (with -Wall -Wextra -Wpedantic) and links against the shared library.
#include "pleat/pleat.h"

#include <cstring>

int main()
{
	plContextDef def = plDefaultContextDef();
	plContext context;
	if ( plCreateContext( &def, &context ) != PLEAT_RESULT_OK )
	{
		return 1;
	}
	int ok = plContext_IsValid( context ) && std::strcmp( plResultString( PLEAT_RESULT_CLAMPED ), "PLEAT_RESULT_CLAMPED" ) == 0;
	ok = ok && plDestroyContext( context ) == PLEAT_RESULT_OK;
	return ok ? 0 : 1;
}
