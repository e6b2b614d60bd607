#include "report_html.hpp"
