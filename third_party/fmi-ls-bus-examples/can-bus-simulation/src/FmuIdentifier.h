#ifndef FMU_IDENTIFIER_H
#define FMU_IDENTIFIER_H

#define FMI3_FUNCTION_PREFIX DemoCanBusSimulation_

#endif
