// PROJ in a stage the table keeps free of it.
#include <proj.h>
