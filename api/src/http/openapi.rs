//! The OpenAPI 3.1 document at `/openapi.json`, built with utoipa from the route table the
//! router is built from; request and answer schemas come from the typed operations.

use super::*;

/// The OpenAPI 3.1 document of [`routes`], with the tools' JSON Schemas as components.
pub fn openapi(service: &Service) -> JsonValue {
    let tools = crate::tools::tools(true);
    let schema_ref = |name: String| Ref::from_schema_name(name);
    let json_content = |name: String| ContentBuilder::new().schema(Some(schema_ref(name))).build();
    let error = ResponseBuilder::new()
        .description("An error: {\"error\": {\"code\", \"message\"}}")
        .content("application/json", json_content("Error".into()))
        .build();
    let mut paths = PathsBuilder::new();
    let mut schemas: BTreeMap<String, JsonValue> = BTreeMap::new();
    for route in routes() {
        let mut op = OperationBuilder::new()
            .summary(Some(route.summary))
            .operation_id(Some(format!(
                "{}{}",
                match route.method {
                    HttpMethod::Post => "post",
                    _ => "get",
                },
                route.path.replace(['/', '{', '}', '.'], "_")
            )));
        if route.path.contains("{id}") {
            op = op.parameter(
                ParameterBuilder::new()
                    .name("id")
                    .parameter_in(ParameterIn::Path)
                    .required(Required::True)
                    .schema(Some(
                        ObjectBuilder::new()
                            .schema_type(Type::Integer)
                            .minimum(Some(0)),
                    )),
            );
        }
        if route.path.contains("{format}") {
            op = op.parameter(
                ParameterBuilder::new()
                    .name("format")
                    .parameter_in(ParameterIn::Path)
                    .required(Required::True)
                    .schema(Some(
                        ObjectBuilder::new()
                            .schema_type(Type::String)
                            .enum_values(Some(
                                opengraph_service::export::ExportFormat::NAMES
                                    .into_iter()
                                    .filter(|n| *n != "neo4j-csv"),
                            )),
                    )),
            );
        }
        if route.path.contains("{name}") {
            op = op.parameter(
                ParameterBuilder::new()
                    .name("name")
                    .parameter_in(ParameterIn::Path)
                    .required(Required::True)
                    .schema(Some(ObjectBuilder::new().schema_type(Type::String))),
            );
        }
        let tool = match route.op {
            Op::Tool(t) | Op::ToolGet(t, _) => tools.iter().find(|x| x.name == t),
            _ => None,
        };
        let ok = match (route.op, tool) {
            (Op::Page, _) => ResponseBuilder::new()
                .description("The viewer's HTML page.")
                .content("text/html", ContentBuilder::new().build())
                .build(),
            (Op::Script, _) => ResponseBuilder::new()
                .description("The viewer's JavaScript.")
                .content("text/javascript", ContentBuilder::new().build())
                .build(),
            (Op::Export, _) => ResponseBuilder::new()
                .description("The map in the asked format.")
                .content("application/json", ContentBuilder::new().build())
                .content("application/graphml+xml", ContentBuilder::new().build())
                .build(),
            (Op::Points, _) => ResponseBuilder::new()
                .description("Little-endian float32 x y z per point (12 bytes, world frame, metres); X-Point-Count gives the count.")
                .content("application/octet-stream", ContentBuilder::new().build())
                .build(),
            (_, Some(t)) => {
                schemas.insert(format!("{}_output", t.name), t.output_schema.clone());
                ResponseBuilder::new()
                    .description("The tool's answer.")
                    .content("application/json", json_content(format!("{}_output", t.name)))
                    .build()
            }
            (op, None) => {
                let name = match op {
                    Op::Health => "Health",
                    Op::Ready => "Ready",
                    Op::Info => "Info",
                    Op::Tools => "ToolList",
                    Op::OpenApi => "OpenApiDocument",
                    Op::View => "View",
                    Op::Ask => "ask_output",
                    _ => "AnyAnswer",
                };
                ResponseBuilder::new()
                    .description("JSON")
                    .content("application/json", json_content(name.into()))
                    .build()
            }
        };
        if let (Op::Tool(_), Some(t)) = (route.op, tool) {
            schemas.insert(format!("{}_input", t.name), t.input_schema.clone());
            op = op.request_body(Some(
                RequestBodyBuilder::new()
                    .required(Some(Required::True))
                    .content(
                        "application/json",
                        json_content(format!("{}_input", t.name)),
                    )
                    .build(),
            ));
        }
        if route.op == Op::Ask {
            op = op.request_body(Some(
                RequestBodyBuilder::new()
                    .required(Some(Required::True))
                    .content("application/json", json_content("ask_input".into()))
                    .build(),
            ));
        }
        if route.op == Op::CallTool {
            op = op.request_body(Some(
                RequestBodyBuilder::new()
                    .content("application/json", json_content("ToolArguments".into()))
                    .build(),
            ));
        }
        op = op.response("200", ok);
        for status in ["400", "401", "404", "413", "500", "503", "504"] {
            op = op.response(status, error.clone());
        }
        paths = paths.path(route.path, PathItem::new(route.method, op.build()));
    }
    let doc = OpenApiBuilder::new()
        .info(
            InfoBuilder::new()
                .title("OpenGraph")
                .version(env!("CARGO_PKG_VERSION"))
                .description(Some(format!(
                    "A 3D scene graph of a street map as a service. Writes {}. MCP (streamable HTTP) is at /mcp.",
                    if service.writes() {
                        "need Authorization: Bearer <token>"
                    } else {
                        "are off on this server"
                    }
                )))
                .build(),
        )
        .paths(paths.build())
        .build();
    let mut v = serde_json::to_value(&doc).unwrap_or_else(|_| json!({}));
    // the tools' JSON Schemas verbatim (OpenAPI 3.1 schemas are JSON Schema 2020-12)
    schemas.insert(
        "Error".into(),
        json!({"type": "object", "required": ["error"], "properties": {"error": {
            "type": "object", "required": ["code", "message"],
            "properties": {"code": {"type": "string"}, "message": {"type": "string"}}}}}),
    );
    schemas.insert(
        "Health".into(),
        json!({"type": "object", "required": ["status"], "properties": {"status": {"const": "ok"}}}),
    );
    schemas.insert(
        "Ready".into(),
        json!({"type": "object", "required": ["status"], "properties": {"status": {"const": "ready"}}}),
    );
    schemas.insert(
        "Info".into(),
        json!({"type": "object", "required": ["nodes", "relationships"]}),
    );
    schemas.insert(
        "ToolList".into(),
        json!({"type": "array", "items": {"type": "object",
            "required": ["name", "description", "input_schema", "output_schema", "writes"]}}),
    );
    schemas.insert(
        "OpenApiDocument".into(),
        json!({"type": "object", "required": ["openapi", "paths"]}),
    );
    schemas.insert("ToolArguments".into(), json!({"type": "object"}));
    schemas.insert(
        "ask_input".into(),
        crate::ops::request_schema_of::<crate::ops::AskRequest>(),
    );
    schemas.insert(
        "ask_output".into(),
        json!({"type": "object", "required": ["question", "model", "steps", "answer"],
               "properties": {"model": {"type": "string"}, "steps": {"type": "array"},
                              "answer": {"type": ["string", "null"]}}}),
    );
    schemas.insert(
        "View".into(),
        json!({"type": "object", "required": ["ground", "bounds", "instances", "lanes", "segments", "colours"],
               "properties": {
                   "bounds": {"type": "array", "items": {"type": "number"}, "minItems": 4, "maxItems": 4},
                   "instances": {"type": "array", "items": {"type": "object",
                       "required": ["id", "semantic_class", "caption", "surface", "points"],
                       "properties": {"points": {"type": "array", "items": {"type": "number"}}}}},
                   "lanes": {"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
                   "segments": {"type": "array", "items": {"type": "object", "required": ["id", "kind", "outline"]}},
                   "colours": {"type": "object", "additionalProperties": {"type": "string", "pattern": "^#[0-9a-f]{6}$"}}}}),
    );
    schemas.insert("AnyAnswer".into(), json!({}));
    v["components"] = json!({"schemas": schemas});
    v
}
